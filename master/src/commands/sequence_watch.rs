//! What watches a sequence that a master renders on workers that dial in (`parrt master`,
//! `parrt cluster`): the timeline's recorder and the live view when their flags ask, started
//! before the run as the master's observers, and closed after it with the run's report.

use super::render_sequence::{
    report_frames, sequence_live, sequence_recorder, write_sequence_timeline, PreparedRef,
    SequenceDone,
};
use crate::cli_args::job_flags::JobFlags;
use crate::live::Live;
use crate::timeline::Recorder;
use parrt_runtime::observer::Observers;
use std::sync::Arc;

/// The recorder and live view of one sequence, and the observers that feed them.
pub struct SequenceWatch {
    /// What the master's config takes (taken once, [`Self::observers`]).
    observers: Observers,
    recorder: Option<Arc<Recorder>>,
    live: Option<Live>,
}

impl SequenceWatch {
    /// Starts what `job`'s flags ask for; the live view's key derives from the workers'
    /// `token`.
    pub fn start(
        job: &JobFlags,
        token: &[u8],
        p: &PreparedRef<'_>,
        tile: u32,
    ) -> anyhow::Result<Self> {
        let mut observers = Observers::default();
        let recorder = sequence_recorder(&mut observers, job.timeline.is_some());
        let live = sequence_live(&job.live, Some(token), p, tile, "distributed")?;
        if let Some(l) = &live {
            observers.0.push(l.observer());
        }
        Ok(SequenceWatch {
            observers,
            recorder,
            live,
        })
    }

    /// The observers for the master's config.
    pub fn observers(&mut self) -> Observers {
        std::mem::take(&mut self.observers)
    }

    /// The run is over: writes the timeline, ends the live view and reports the frames
    /// written, as `who`.
    pub fn finish(
        self,
        who: &str,
        job: &JobFlags,
        p: &PreparedRef<'_>,
        tile: u32,
        r: &SequenceDone,
    ) -> anyhow::Result<()> {
        write_sequence_timeline(
            self.recorder.as_deref(),
            job.timeline.as_deref(),
            p,
            tile,
            r.trace_s,
        )?;
        if let Some(l) = self.live {
            l.end(true);
        }
        report_frames(who, p.outputs, r);
        Ok(())
    }
}
