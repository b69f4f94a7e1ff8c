//! Sensors' white noise: Gaussian, drawn sample by sample and channel by channel from a
//! seeded stream. The studies' measurements and a plant stepped by a master (a plant FMU)
//! draw it alike: the same stream and σ give the same noise, sample by sample.

use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

/// The noise of `N` channels.
#[derive(Debug, Clone)]
pub struct SensorNoise<const N: usize> {
    rng: ChaCha8Rng,
    std: [f64; N],
}

impl<const N: usize> SensorNoise<N> {
    /// The noise drawn from `rng`, of standard deviations `std`.
    pub fn new(rng: ChaCha8Rng, std: [f64; N]) -> Self {
        Self { rng, std }
    }

    /// The next sample's measurement of `row`: each channel plus its σ times a draw.
    pub fn measure(&mut self, row: [f64; N]) -> [f64; N] {
        let mut z = row;
        for (zi, s) in z.iter_mut().zip(self.std) {
            let e: f64 = StandardNormal.sample(&mut self.rng);
            *zi += s * e;
        }
        z
    }

    /// The stream, where the draws left it.
    pub fn into_stream(self) -> ChaCha8Rng {
        self.rng
    }

    /// Where the stream is (to save and restore it).
    pub fn position(&self) -> u128 {
        self.rng.get_word_pos()
    }

    /// Moves the stream to `position` (one [`SensorNoise::position`] gave).
    pub fn set_position(&mut self, position: u128) {
        self.rng.set_word_pos(position);
    }
}
