//! The instruction-set tier of this process, chosen in this one place: `scalar` (one lane at a
//! time, the portable definition of every answer), `sse2` (four-lane SSE2 kernels, the x86-64
//! baseline), `avx2` (the AVX kernels of the leaf tests, the BVH walks compiled with AVX around
//! the eight-box node test, and the AVX2 film conversion) and
//! `avx512` (a CPU with AVX-512 F, BW, DQ and VL: the sixteen-ray packet kernels in one
//! AVX-512 register, the `avx2` kernels elsewhere). Every tier gives the same bits: the kernels do the scalar test's IEEE
//! operations lane by lane, with no FMA and no approximate reciprocal.
//!
//! The tier is the best this CPU runs, or the one `PARRT_ISA` names. The binaries call [`init`]
//! first thing and refuse an unknown or unsupported name (exit 2); the kernels ask
//! [`current`], one relaxed atomic load. This module never decides an exit code.

use std::fmt;
use std::str::FromStr;
use std::sync::atomic::{AtomicU8, Ordering};

/// The environment variable that forces a tier.
pub const ENV: &str = "PARRT_ISA";

/// An instruction-set tier, from the narrowest to the widest.
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize, serde::Deserialize,
)]
#[serde(rename_all = "lowercase")]
pub enum Isa {
    /// One lane at a time: the portable kernels.
    Scalar,
    /// Four-lane SSE2 kernels.
    Sse2,
    /// The AVX kernels (and AVX2 where one is written for it).
    Avx2,
    /// AVX-512 F, BW, DQ and VL: the sixteen-ray kernels in one register, the `avx2` kernels
    /// otherwise.
    Avx512,
}

/// Why a tier cannot be used.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum IsaError {
    /// The name is no tier.
    #[error("{ENV}={value:?} is not a tier: expected one of scalar, sse2, avx2, avx512")]
    Unknown {
        /// The name given (lossily decoded when it was not UTF-8).
        value: String,
    },
    /// The CPU lacks the instructions the tier needs.
    #[error(
        "{ENV}={tier}: this CPU lacks {needs}; the tiers it runs are {}",
        Isa::supported_names()
    )]
    Unsupported {
        /// The tier asked for.
        tier: Isa,
        /// What the tier needs.
        needs: &'static str,
    },
}

impl Isa {
    /// Every tier, narrowest first.
    pub const ALL: [Isa; 4] = [Isa::Scalar, Isa::Sse2, Isa::Avx2, Isa::Avx512];

    /// The tier's name as `PARRT_ISA` takes it and the reports print it.
    pub fn name(self) -> &'static str {
        match self {
            Isa::Scalar => "scalar",
            Isa::Sse2 => "sse2",
            Isa::Avx2 => "avx2",
            Isa::Avx512 => "avx512",
        }
    }

    /// What the tier needs of the CPU, in words.
    pub fn needs(self) -> &'static str {
        match self {
            Isa::Scalar => "nothing",
            Isa::Sse2 => "an x86-64 CPU (SSE2)",
            Isa::Avx2 => "AVX and AVX2",
            Isa::Avx512 => "AVX2 and AVX-512 F, BW, DQ and VL",
        }
    }

    /// Whether this CPU runs the tier.
    pub fn supported(self) -> bool {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::is_x86_feature_detected as has;
            match self {
                Isa::Scalar | Isa::Sse2 => true,
                Isa::Avx2 => has!("avx") && has!("avx2"),
                Isa::Avx512 => {
                    Isa::Avx2.supported()
                        && has!("avx512f")
                        && has!("avx512bw")
                        && has!("avx512dq")
                        && has!("avx512vl")
                }
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            self == Isa::Scalar
        }
    }

    /// The widest tier this CPU runs.
    pub fn best() -> Isa {
        Isa::ALL
            .into_iter()
            .rev()
            .find(|t| t.supported())
            .unwrap_or(Isa::Scalar)
    }

    /// The tiers this CPU runs, narrowest first.
    pub fn supported_tiers() -> Vec<Isa> {
        Isa::ALL.into_iter().filter(|t| t.supported()).collect()
    }

    /// Whether the four-lane SSE2 kernels run (every tier but `scalar`).
    #[inline(always)]
    pub fn sse2(self) -> bool {
        self >= Isa::Sse2
    }

    /// Whether the AVX kernels run (`avx2` and `avx512`).
    #[inline(always)]
    pub fn avx(self) -> bool {
        self >= Isa::Avx2
    }

    /// Whether the AVX-512 kernels run (`avx512`).
    #[inline(always)]
    pub fn avx512(self) -> bool {
        self >= Isa::Avx512
    }

    /// `self` if this CPU runs it, else why not.
    pub fn check(self) -> Result<Isa, IsaError> {
        if self.supported() {
            Ok(self)
        } else {
            Err(IsaError::Unsupported {
                tier: self,
                needs: self.needs(),
            })
        }
    }

    fn supported_names() -> String {
        let names: Vec<&str> = Isa::supported_tiers().iter().map(|t| t.name()).collect();
        names.join(", ")
    }

    fn from_u8(v: u8) -> Isa {
        match v {
            0 => Isa::Scalar,
            1 => Isa::Sse2,
            2 => Isa::Avx2,
            _ => Isa::Avx512,
        }
    }
}

impl fmt::Display for Isa {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Isa {
    type Err = IsaError;

    /// A tier by its name, in any case (`scalar`, `sse2`, `avx2`, `avx512`).
    fn from_str(s: &str) -> Result<Isa, IsaError> {
        Isa::ALL
            .into_iter()
            .find(|t| t.name().eq_ignore_ascii_case(s.trim()))
            .ok_or_else(|| IsaError::Unknown {
                value: s.to_string(),
            })
    }
}

/// The process's tier as `Isa as u8`, or [`UNSET`] before the first [`current`] or [`init`].
static TIER: AtomicU8 = AtomicU8::new(UNSET);
const UNSET: u8 = u8::MAX;

/// The tier `PARRT_ISA` asks for, checked against this CPU; the best this CPU runs when the
/// variable is unset or empty.
pub fn from_env() -> Result<Isa, IsaError> {
    match std::env::var_os(ENV) {
        None => Ok(Isa::best()),
        Some(v) if v.is_empty() => Ok(Isa::best()),
        Some(v) => match v.to_str() {
            Some(s) => s.parse::<Isa>()?.check(),
            None => Err(IsaError::Unknown {
                value: v.to_string_lossy().into_owned(),
            }),
        },
    }
}

/// Chooses the process's tier from `PARRT_ISA` and this CPU ([`from_env`]); the binaries call
/// it before anything else and refuse the error with exit 2.
pub fn init() -> Result<Isa, IsaError> {
    let tier = from_env()?;
    TIER.store(tier as u8, Ordering::Relaxed);
    Ok(tier)
}

/// The process's tier: what [`init`] or [`force`] set, else chosen now as [`init`] would (the
/// best this CPU runs when `PARRT_ISA` is not usable: a library caller that wants the refusal
/// calls [`init`]).
#[inline(always)]
pub fn current() -> Isa {
    let v = TIER.load(Ordering::Relaxed);
    if v == UNSET {
        return choose();
    }
    Isa::from_u8(v)
}

#[cold]
#[inline(never)]
fn choose() -> Isa {
    let tier = from_env().unwrap_or_else(|_| Isa::best());
    match TIER.compare_exchange(UNSET, tier as u8, Ordering::Relaxed, Ordering::Relaxed) {
        Ok(_) => tier,
        Err(other) => Isa::from_u8(other),
    }
}

/// Sets the tier of the whole process, for tests and benchmarks that compare tiers in one
/// process (the renderer reads it at every kernel call: change it only between renders).
/// Returns the tier it replaced, or why `tier` cannot run here.
pub fn force(tier: Isa) -> Result<Isa, IsaError> {
    tier.check()?;
    let before = current();
    TIER.store(tier as u8, Ordering::Relaxed);
    Ok(before)
}

/// A kernel with a body per tier, entered through [`dispatch`]: the one place a tier's code is
/// chosen and compiled with the tier's instruction sets enabled. The body, [`Kernel::run`],
/// is generic over the tier and picks its lane types ([`crate::lanes`]) from [`Tier::ISA`]
/// (a constant, so the choice costs nothing); it must be `#[inline(always)]` so that it is
/// compiled inside the tier's entry, with the tier's instructions.
pub trait Kernel {
    /// What the kernel answers.
    type Output;
    /// The kernel's body on tier `T`.
    fn run<T: Tier>(self) -> Self::Output;
}

/// A tier as a type, for [`Kernel::run`].
pub trait Tier {
    /// The tier.
    const ISA: Isa;
}

/// The `scalar` tier as a type.
pub struct OnScalar;
/// The `sse2` tier as a type.
pub struct OnSse2;
/// The `avx2` tier as a type.
pub struct OnAvx2;
/// The `avx512` tier as a type.
pub struct OnAvx512;

impl Tier for OnScalar {
    const ISA: Isa = Isa::Scalar;
}
impl Tier for OnSse2 {
    const ISA: Isa = Isa::Sse2;
}
impl Tier for OnAvx2 {
    const ISA: Isa = Isa::Avx2;
}
impl Tier for OnAvx512 {
    const ISA: Isa = Isa::Avx512;
}

/// Runs `k` with the code of the process's tier ([`current`]).
#[inline(always)]
pub fn dispatch<K: Kernel>(k: K) -> K::Output {
    // SAFETY: `current` is only ever a tier this CPU runs (`init`, `force` and `choose` check).
    unsafe { run_on(current(), k) }
}

/// Runs `k` with the code of `tier` whatever the process's tier, or `None` when this CPU does
/// not run `tier` (for the tests that compare the tiers' kernels in one process).
pub fn dispatch_on<K: Kernel>(tier: Isa, k: K) -> Option<K::Output> {
    // SAFETY: checked just now.
    tier.supported().then(|| unsafe { run_on(tier, k) })
}

/// Runs `k` with the body of `tier` inline in the caller, not in the tier's compiled entry: for
/// a small kernel called per node from a walk that is itself compiled for the tier (a call per
/// node would cost more than the kernel). The body's lane operations compile to single
/// instructions only where the caller enables the lane type's instruction set; elsewhere they
/// become calls (correct, slower), so a body should pick lanes the caller is compiled for.
///
/// # Safety
/// This CPU must run `tier`.
#[inline(always)]
pub unsafe fn run_inline<K: Kernel>(tier: Isa, k: K) -> K::Output {
    match tier {
        Isa::Avx512 => k.run::<OnAvx512>(),
        Isa::Avx2 => k.run::<OnAvx2>(),
        Isa::Sse2 => k.run::<OnSse2>(),
        Isa::Scalar => k.run::<OnScalar>(),
    }
}

/// # Safety
/// This CPU must run `tier`.
#[inline(always)]
unsafe fn run_on<K: Kernel>(tier: Isa, k: K) -> K::Output {
    match tier {
        #[cfg(target_arch = "x86_64")]
        Isa::Avx512 => on_avx512(k),
        #[cfg(target_arch = "x86_64")]
        Isa::Avx2 => on_avx2(k),
        #[cfg(target_arch = "x86_64")]
        Isa::Sse2 => on_sse2(k),
        _ => on_scalar(k),
    }
}

#[inline(never)]
fn on_scalar<K: Kernel>(k: K) -> K::Output {
    k.run::<OnScalar>()
}

#[cfg(target_arch = "x86_64")]
#[inline(never)]
fn on_sse2<K: Kernel>(k: K) -> K::Output {
    k.run::<OnSse2>()
}

/// # Safety
/// The CPU must support AVX and AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx,avx2")]
#[inline(never)]
unsafe fn on_avx2<K: Kernel>(k: K) -> K::Output {
    k.run::<OnAvx2>()
}

/// # Safety
/// The CPU must support AVX2 and AVX-512 F, BW, DQ and VL.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx,avx2,avx512f,avx512bw,avx512dq,avx512vl")]
#[inline(never)]
unsafe fn on_avx512<K: Kernel>(k: K) -> K::Output {
    k.run::<OnAvx512>()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_order_is_narrowest_first() {
        for t in Isa::ALL {
            assert_eq!(t.name().parse::<Isa>(), Ok(t));
            assert_eq!(t.name().to_uppercase().parse::<Isa>(), Ok(t));
            assert_eq!(Isa::from_u8(t as u8), t);
        }
        assert!(Isa::Scalar < Isa::Sse2 && Isa::Sse2 < Isa::Avx2 && Isa::Avx2 < Isa::Avx512);
        assert!(!Isa::Scalar.sse2() && Isa::Sse2.sse2() && !Isa::Sse2.avx());
        assert!(Isa::Avx2.avx() && Isa::Avx512.avx());
        assert!(Isa::Avx512.avx512() && !Isa::Avx2.avx512());
    }

    #[test]
    fn unknown_names_are_refused_with_the_choices() {
        for bad in ["avx", "sse4", "AVX-512", "fast", "0"] {
            let e = bad.parse::<Isa>().unwrap_err();
            assert_eq!(
                e,
                IsaError::Unknown {
                    value: bad.to_string()
                }
            );
            let msg = e.to_string();
            assert!(msg.contains("PARRT_ISA") && msg.contains("avx512"), "{msg}");
        }
    }

    #[test]
    fn scalar_runs_everywhere_and_best_is_supported() {
        assert!(Isa::Scalar.supported());
        assert!(Isa::best().supported());
        let tiers = Isa::supported_tiers();
        assert_eq!(tiers.first(), Some(&Isa::Scalar));
        assert_eq!(tiers.last(), Some(&Isa::best()));
        // Tiers nest: a CPU that runs one runs every narrower one.
        assert_eq!(tiers, Isa::ALL[..tiers.len()].to_vec());
    }

    #[test]
    fn serde_names_are_the_tier_names() {
        for t in Isa::ALL {
            assert_eq!(
                serde_json::to_value(t).unwrap(),
                serde_json::json!(t.name())
            );
        }
    }
}
