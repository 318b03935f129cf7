//! The one pseudo-random generator of the crate: SplitMix64, seeded, with the
//! same sequence on every target. Stages that draw (initial generators, samples)
//! and tests use it; nothing else in core is random.

/// SplitMix64: a tiny seeded generator with good statistical quality for sampling.
/// Identical sequences on every platform.
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    /// The generator of `seed`: every stage seeds it from
    /// [`Params::seed`](crate::params::Params::seed) or a constant of its own.
    pub fn new(seed: u64) -> Self {
        Rng(seed ^ 0x6A09_E667_F3BC_C908)
    }

    /// The generator whose internal state is `state` (no mixing of the seed):
    /// the first [`Rng::next_u64`] is SplitMix64's finaliser applied to
    /// `state + 0x9E3779B97F4A7C15`, a well-mixed hash of `state`.
    pub fn from_state(state: u64) -> Self {
        Rng(state)
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `0..n` (n > 0) without modulo bias worth caring about (n < 2^32).
    pub fn below(&mut self, n: u32) -> u32 {
        (((self.next_u64() >> 32) * n as u64) >> 32) as u32
    }

    /// Uniform in [0, 1).
    pub fn unit_f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
}
