//! How a command watches its render: the observers the flags ask for (the progress bar, the
//! timeline's recorder, the live view), started before the render and ended after it. Every
//! watcher is a plain [`Observer`] of the render, SMP or distributed alike; what a bad flag
//! means for the exit code is decided here, not by the watchers.

use crate::cli_args::live::LiveArgs;
use crate::live::state::JobInfo;
use crate::live::Live;
use crate::progress::Progress;
use crate::timeline::Recorder;
use parrt_runtime::observer::{Observer, Observers};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Starts the live view `args` ask for (`None` without `--http`): a bad flag is bad input
/// (exit 2), an address that cannot be served is not.
pub fn start_live(args: &LiveArgs, token: Option<&[u8]>) -> anyhow::Result<Option<Live>> {
    args.options()?
        .map(|opts| Live::start(&opts, token))
        .transpose()
}

/// The observers of a distributed render: the progress bar (drawn only on a terminal), the
/// timeline's recorder and the live view, if asked.
pub fn watchers(recorder: Option<&Arc<Recorder>>, live: Option<&Live>) -> Observers {
    let mut v: Vec<Arc<dyn Observer>> = vec![Arc::new(Progress::new(true))];
    if let Some(r) = recorder {
        v.push(r.clone());
    }
    if let Some(l) = live {
        v.push(l.observer());
    }
    Observers(v)
}

/// The watchers of a distributed render asked for on the command line (`--timeline`,
/// `--http`), for `parrt master` and `parrt cluster`.
pub struct Watch {
    timeline: Option<(PathBuf, Arc<Recorder>)>,
    live: Option<Live>,
    job: JobInfo,
}

impl Watch {
    /// Watchers writing the timeline to `timeline` and feeding `live`, for `job`.
    pub fn new(timeline: Option<&Path>, live: Option<Live>, job: JobInfo) -> Self {
        if let Some(l) = &live {
            l.set_job(job.clone());
        }
        Watch {
            timeline: timeline.map(|p| (p.to_path_buf(), Arc::new(Recorder::new()))),
            live,
            job,
        }
    }

    /// The observers to give the render.
    pub fn observers(&self) -> Observers {
        watchers(self.timeline.as_ref().map(|t| &t.1), self.live.as_ref())
    }

    /// Writes the timeline, then serves the live view's last state for its linger time.
    pub fn end(self, trace_s: f64) -> anyhow::Result<()> {
        if let Some((path, rec)) = &self.timeline {
            let job = crate::timeline::Job {
                scene: &self.job.scene,
                width: self.job.width,
                height: self.job.height,
                tile_size: self.job.tile_size,
            };
            rec.timeline(&job, trace_s).write(path)?;
        }
        if let Some(l) = self.live {
            l.end(true);
        }
        Ok(())
    }
}
