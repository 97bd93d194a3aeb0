//! A seeded exploration generator whose exact position can be saved and resumed.

use crate::error::AdvisorError;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use serde::{Deserialize, Serialize};

/// ChaCha8 with (seed, stream, word position) as its serialised form, so a
/// saved advisor resumes the exact same sequence of draws.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(into = "RngState", try_from = "RngState")]
pub(crate) struct ExplorationRng {
    rng: ChaCha8Rng,
}

/// Serialised generator position.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct RngState {
    seed: [u8; 32],
    stream: u64,
    /// Word position, high and low 64 bits.
    word_pos: [u64; 2],
}

impl From<ExplorationRng> for RngState {
    fn from(r: ExplorationRng) -> Self {
        let pos = r.rng.get_word_pos();
        Self {
            seed: r.rng.get_seed(),
            stream: r.rng.get_stream(),
            word_pos: [(pos >> 64) as u64, pos as u64],
        }
    }
}

impl TryFrom<RngState> for ExplorationRng {
    type Error = AdvisorError;
    fn try_from(s: RngState) -> Result<Self, Self::Error> {
        let pos = (u128::from(s.word_pos[0]) << 64) | u128::from(s.word_pos[1]);
        if pos >= 1u128 << 68 {
            return Err(AdvisorError::State(format!(
                "generator word position {pos} out of range"
            )));
        }
        let mut rng = ChaCha8Rng::from_seed(s.seed);
        rng.set_stream(s.stream);
        rng.set_word_pos(pos);
        Ok(Self { rng })
    }
}

impl ExplorationRng {
    /// Generator for `seed`, independent stream `stream` (one per agent).
    pub(crate) fn new(seed: u64, stream: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        rng.set_stream(stream);
        Self { rng }
    }

    /// One standard-normal draw.
    pub(crate) fn standard_normal(&mut self) -> f64 {
        StandardNormal.sample(&mut self.rng)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn resumes_mid_sequence() {
        let mut a = ExplorationRng::new(7, 2);
        for _ in 0..5 {
            a.standard_normal();
        }
        let saved = serde_json::to_string(&a).unwrap();
        let mut b: ExplorationRng = serde_json::from_str(&saved).unwrap();
        for _ in 0..20 {
            assert_eq!(a.standard_normal(), b.standard_normal());
        }
        let mut c = ExplorationRng::new(7, 3);
        assert_ne!(
            ExplorationRng::new(7, 2).standard_normal(),
            c.standard_normal()
        );
    }
}
