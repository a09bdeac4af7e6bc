//! The one dispatch of the four-lane leaf kernels (four primitives against one ray, or one
//! cone against four rays): a test says its lane kernel and its portable loop
//! ([`FourLanes`]); [`four`] runs it with the code of the process's tier, [`four_on`] with a
//! tier given (for the tests that compare the tiers). Four SSE2 lanes serve every x86-64 tier
//! (in their VEX form where AVX is enabled); the portable loop serves `scalar` and other
//! targets.

use crate::isa::{Isa, Kernel, Tier};
use crate::lanes::Lanes;

/// A four-lane test with its arguments.
pub trait FourLanes {
    /// Its answers.
    type Output;
    /// The lane kernel.
    fn lanes<L: Lanes<Elem = f32>>(self) -> Self::Output;
    /// The portable loop: the scalar test lane by lane.
    fn portable(self) -> Self::Output;
}

/// A four-lane test as the kernel [`crate::isa::dispatch`] runs.
struct OnFour<F>(F);

impl<F: FourLanes> Kernel for OnFour<F> {
    type Output = F::Output;

    #[inline(always)]
    fn run<T: Tier>(self) -> F::Output {
        #[cfg(target_arch = "x86_64")]
        if T::ISA.sse2() {
            return self.0.lanes::<crate::lanes::X4>();
        }
        self.0.portable()
    }
}

/// `test` with the kernel of the process's tier.
#[inline(always)]
pub fn four<F: FourLanes>(test: F) -> F::Output {
    crate::isa::dispatch(OnFour(test))
}

/// `test` with the code of `tier`, or `None` when this CPU does not run `tier`.
pub fn four_on<F: FourLanes>(tier: Isa, test: F) -> Option<F::Output> {
    crate::isa::dispatch_on(tier, OnFour(test))
}

/// One ray against four primitives of one kind (`used` of them counting, each within
/// `t_max`) with the kernel of the process's tier: four triangles against a prepared ray
/// ([`super::leaf_triangles`]), four spheres ([`super::leaf_spheres`]) or four cones
/// ([`super::cone::lanes`]) against a ray, gathered on the spot (`[&P; 4]`) or already in
/// lanes (the same answers bit for bit).
#[inline]
pub fn intersect4<'a, Q, S>(
    ray: &'a Q,
    src: &'a S,
    used: usize,
    t_max: f32,
) -> <FourOnRay<'a, Q, S> as FourLanes>::Output
where
    FourOnRay<'a, Q, S>: FourLanes,
{
    four(FourOnRay::new(ray, src, used, t_max))
}

/// One ray (`Q`: a ray, or a ray prepared for the triangle test) against the four primitives
/// of `src`, lanes `0..used` counting, each within `t_max`: the arguments of a leaf kernel.
#[derive(Clone, Copy)]
pub struct FourOnRay<'a, Q, S> {
    /// The ray.
    pub ray: &'a Q,
    /// The four primitives, gathered on the spot or already in lanes.
    pub src: &'a S,
    /// The lanes that count (1..=4).
    pub used: usize,
    /// The ray's bound, inclusive.
    pub t_max: f32,
}

impl<'a, Q, S> FourOnRay<'a, Q, S> {
    /// The arguments in the order the kernels take them.
    #[inline(always)]
    pub fn new(ray: &'a Q, src: &'a S, used: usize, t_max: f32) -> Self {
        FourOnRay {
            ray,
            src,
            used,
            t_max,
        }
    }
}

/// The answers of `test` with the process's tier and with every tier's code this CPU runs
/// (for the tests that compare the tiers).
#[cfg(test)]
pub(crate) fn every_tier<F: FourLanes + Copy>(test: F) -> Vec<F::Output> {
    let tiers = Isa::ALL.into_iter().filter_map(|tier| four_on(tier, test));
    std::iter::once(four(test)).chain(tiers).collect()
}

/// What two kernels' answers must agree on (test builds): the lanes hit, each with the bits of
/// what was answered there.
#[cfg(test)]
pub(crate) trait HitBits {
    /// The lanes hit with their answers' bits.
    fn hit_bits(&self) -> Vec<(usize, Vec<u32>)>;
}

/// The lanes set in `mask`, each with the bits of every one of `values` there (for
/// [`HitBits`]).
#[cfg(test)]
pub(crate) fn lanes_bits(mask: u32, values: &[&[f32]]) -> Vec<(usize, Vec<u32>)> {
    let bits = |i: usize| values.iter().map(|v| v[i].to_bits()).collect();
    (0..32)
        .filter(|i| mask & (1 << i) != 0)
        .map(|i| (i, bits(i)))
        .collect()
}

/// Asserts that every answer of `got` agrees with `want` bit for bit (`case` names the inputs
/// in the message).
#[cfg(test)]
pub(crate) fn assert_agree<H: HitBits>(want: &H, got: &[H], case: &str) {
    for g in got {
        assert_eq!(g.hit_bits(), want.hit_bits(), "{case}");
    }
}
