//! What a cluster launcher (`srun`, Open MPI's `mpirun`, MPICH's `mpiexec`) tells each process
//! it starts, read from the environment: its rank, the number of ranks, the job's id and the
//! cores it may use. No MPI library: only environment variables.

use sha2::{Digest, Sha256};
use thiserror::Error;

/// The variables of each launcher: (launcher, rank variable, size variable).
pub const LAUNCHERS: [(&str, &str, &str); 3] = [
    ("Slurm", "SLURM_PROCID", "SLURM_NTASKS"),
    ("Open MPI", "OMPI_COMM_WORLD_RANK", "OMPI_COMM_WORLD_SIZE"),
    ("PMI (MPICH/Hydra)", "PMI_RANK", "PMI_SIZE"),
];

/// The most ranks a job may have (the master must hold a connection to each).
pub const MAX_RANKS: usize = 4096;

/// This process's place in the job.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Rank {
    /// 0 is the master.
    pub rank: usize,
    /// Ranks in the job.
    pub size: usize,
    /// The launcher whose variables were read.
    pub launcher: &'static str,
}

/// Errors reading the launcher's environment (all bad input: exit 2).
#[derive(Debug, Error, PartialEq, Eq)]
pub enum LauncherError {
    /// No launcher's variables are set.
    #[error("no rank in the environment: start `parrt cluster` with srun, mpirun or mpiexec (it reads SLURM_PROCID/SLURM_NTASKS, OMPI_COMM_WORLD_RANK/OMPI_COMM_WORLD_SIZE or PMI_RANK/PMI_SIZE)")]
    NoLauncher,
    /// A variable is set but not a number in range.
    #[error("{var}={value:?} is not valid: {why}")]
    Bad {
        /// The variable.
        var: String,
        /// Its value.
        value: String,
        /// What is wrong.
        why: String,
    },
    /// Two launchers' variables say different things.
    #[error("the launcher variables disagree: {0}")]
    Disagree(String),
}

fn number(var: &str, value: &str) -> Result<usize, LauncherError> {
    value.trim().parse().map_err(|_| LauncherError::Bad {
        var: var.into(),
        value: value.into(),
        why: "not a whole number".into(),
    })
}

/// Reads the rank and size from `env` (a lookup, `std::env::var` in the program): every
/// launcher whose two variables are set must agree; the rank must be below the size, the size
/// from 2 (a master and a worker) to [`MAX_RANKS`].
pub fn rank_from(env: &dyn Fn(&str) -> Option<String>) -> Result<Rank, LauncherError> {
    let mut found: Vec<Rank> = Vec::new();
    for (launcher, rank_var, size_var) in LAUNCHERS {
        let (Some(r), Some(s)) = (env(rank_var), env(size_var)) else {
            continue;
        };
        let rank = number(rank_var, &r)?;
        let size = number(size_var, &s)?;
        if !(2..=MAX_RANKS).contains(&size) {
            return Err(LauncherError::Bad {
                var: size_var.into(),
                value: s,
                why: format!(
                    "`parrt cluster` needs from 2 to {MAX_RANKS} ranks (rank 0 is the master, the others render)"
                ),
            });
        }
        if rank >= size {
            return Err(LauncherError::Bad {
                var: rank_var.into(),
                value: r,
                why: format!("not below {size_var}={size}"),
            });
        }
        found.push(Rank {
            rank,
            size,
            launcher,
        });
    }
    let first = found.first().cloned().ok_or(LauncherError::NoLauncher)?;
    if let Some(other) = found
        .iter()
        .find(|o| (o.rank, o.size) != (first.rank, first.size))
    {
        return Err(LauncherError::Disagree(format!(
            "{} says rank {} of {}, {} says rank {} of {}",
            first.launcher, first.rank, first.size, other.launcher, other.rank, other.size
        )));
    }
    Ok(first)
}

/// Variables a launcher sets alike in every rank of one job (no rank- or node-specific ones),
/// hashed into the job id when no launcher names the job.
const SHARED_PREFIXES: [&str; 4] = ["PMI_", "PMIX_", "HYDRA_", "OMPI_"];
const PER_RANK: [&str; 8] = [
    "PMI_RANK",
    "PMI_FD",
    "PMI_PORT",
    "PMI_ID",
    "PMIX_RANK",
    "OMPI_COMM_WORLD_RANK",
    "OMPI_COMM_WORLD_LOCAL_RANK",
    "OMPI_COMM_WORLD_NODE_RANK",
];

/// The job's id, the same in every rank of one job and different between jobs: Slurm's job and
/// step id, Open MPI's job id (or its PMIx namespace), else a hash of the launcher variables
/// every rank shares (`env-…`; two jobs of the same shape started alike may then collide, and
/// the second is refused because the first's rendezvous file exists).
pub fn job_id(vars: &[(String, String)]) -> String {
    let get = |k: &str| {
        vars.iter()
            .find(|(n, _)| n == k)
            .map(|(_, v)| v.as_str())
            .filter(|v| !v.is_empty())
    };
    if let Some(j) = get("SLURM_JOB_ID") {
        return match get("SLURM_STEP_ID") {
            Some(s) => format!("slurm-{j}.{s}"),
            None => format!("slurm-{j}"),
        };
    }
    for k in [
        "OMPI_MCA_ess_base_jobid",
        "OMPI_MCA_orte_ess_jobid",
        "PMIX_NAMESPACE",
    ] {
        if let Some(j) = get(k) {
            return format!("ompi-{j}");
        }
    }
    let mut shared: Vec<&(String, String)> = vars
        .iter()
        .filter(|(n, _)| {
            SHARED_PREFIXES.iter().any(|p| n.starts_with(p)) && !PER_RANK.contains(&n.as_str())
        })
        .collect();
    shared.sort();
    let mut h = Sha256::new();
    for (n, v) in shared {
        h.update(n.as_bytes());
        h.update([0]);
        h.update(v.as_bytes());
        h.update([0]);
    }
    let digest = h.finalize();
    let hex: String = digest[..8].iter().map(|b| format!("{b:02x}")).collect();
    format!("env-{hex}")
}

/// The render threads of a worker rank: `SLURM_CPUS_PER_TASK` when set, else the cores this
/// process may run on (its CPU affinity, which launchers bind), else 1.
pub fn default_threads(env: &dyn Fn(&str) -> Option<String>) -> usize {
    if let Some(n) = env("SLURM_CPUS_PER_TASK")
        .and_then(|v| v.trim().parse::<usize>().ok())
        .filter(|&n| n > 0)
    {
        return n;
    }
    std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;

    fn env(pairs: &[(&str, &str)]) -> impl Fn(&str) -> Option<String> {
        let m: HashMap<String, String> = pairs
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect();
        move |k| m.get(k).cloned()
    }

    #[test]
    fn each_launcher_is_read() {
        for (launcher, r, s) in LAUNCHERS {
            let got = rank_from(&env(&[(r, "2"), (s, "3")])).unwrap();
            assert_eq!((got.rank, got.size, got.launcher), (2, 3, launcher));
        }
        // Two launchers agreeing (srun --mpi=pmi2 sets both).
        let both = env(&[
            ("SLURM_PROCID", "1"),
            ("SLURM_NTASKS", "4"),
            ("PMI_RANK", "1"),
            ("PMI_SIZE", "4"),
        ]);
        assert_eq!(rank_from(&both).unwrap().rank, 1);
    }

    #[test]
    fn missing_bad_or_disagreeing_variables_are_refused() {
        assert_eq!(rank_from(&env(&[])), Err(LauncherError::NoLauncher));
        assert_eq!(
            rank_from(&env(&[("SLURM_PROCID", "0")])),
            Err(LauncherError::NoLauncher)
        );
        for (r, s, want) in [
            ("x", "3", "not a whole number"),
            ("3", "3", "not below"),
            ("0", "1", "from 2"),
            ("0", "100000", "from 2"),
            ("-1", "3", "not a whole number"),
        ] {
            let e = rank_from(&env(&[("SLURM_PROCID", r), ("SLURM_NTASKS", s)])).unwrap_err();
            assert!(e.to_string().contains(want), "{e}");
        }
        let e = rank_from(&env(&[
            ("SLURM_PROCID", "0"),
            ("SLURM_NTASKS", "3"),
            ("OMPI_COMM_WORLD_RANK", "1"),
            ("OMPI_COMM_WORLD_SIZE", "3"),
        ]))
        .unwrap_err();
        assert!(matches!(e, LauncherError::Disagree(_)), "{e}");
    }

    fn vars(pairs: &[(&str, &str)]) -> Vec<(String, String)> {
        pairs
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect()
    }

    #[test]
    fn job_ids_name_the_job_not_the_rank() {
        assert_eq!(
            job_id(&vars(&[("SLURM_JOB_ID", "42"), ("SLURM_STEP_ID", "1")])),
            "slurm-42.1"
        );
        assert_eq!(
            job_id(&vars(&[
                ("OMPI_MCA_ess_base_jobid", "123"),
                ("PMIX_RANK", "1")
            ])),
            "ompi-123"
        );
        let a = job_id(&vars(&[
            ("PMI_RANK", "0"),
            ("PMI_SIZE", "3"),
            ("HYDRA_X", "a"),
        ]));
        let b = job_id(&vars(&[
            ("PMI_RANK", "2"),
            ("PMI_SIZE", "3"),
            ("HYDRA_X", "a"),
        ]));
        let c = job_id(&vars(&[
            ("PMI_RANK", "0"),
            ("PMI_SIZE", "3"),
            ("HYDRA_X", "b"),
        ]));
        assert_eq!(a, b);
        assert_ne!(a, c);
        assert!(a.starts_with("env-"));
    }

    #[test]
    fn threads_follow_slurm_then_affinity() {
        assert_eq!(default_threads(&env(&[("SLURM_CPUS_PER_TASK", "7")])), 7);
        assert!(default_threads(&env(&[("SLURM_CPUS_PER_TASK", "x")])) >= 1);
    }
}
