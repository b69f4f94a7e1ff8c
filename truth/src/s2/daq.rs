//! The vehicle's data acquisition: how the accelerometers' continuous signals become
//! samples. A DAQ of today (a sigma-delta converter per channel) low-passes each channel
//! with a linear-phase digital filter before it decimates, so that nothing above half the
//! sampling rate folds into the band, and time-stamps the samples for the filter's constant
//! group delay. [`AntiAlias`] is that filter, applied to the truth's accelerations at its
//! integration step; its delay is compensated as the DAQ's time stamps do, so it is
//! centred on the sample instant.
//!
//! Without it, sampling the truth point by point at 200 Hz folds the weld's 0.1 m wave
//! (222 Hz at 80 km/h) and the wheels' impact response into the band, where the estimator
//! reads them as forces (the sweep measured a weld correlation of 0.56 at 80 km/h and 0.31
//! at 160 km/h, against 0.98 at 120 km/h, where the folded tones happened to miss).
//!
//! Shared by every recorded truth (S2's and S3's): [`check_recording`], what a recording's
//! settings must be, and [`with_noise`], the sensors' white noise.

use estimator::math;
use std::f64::consts::PI;

use rand_chacha::ChaCha8Rng;

use crate::sensor_noise::SensorNoise;

/// Checks that a recording can be made: a positive speed and duration, a rate whose sample
/// time is a whole number of the truth's integration steps `dt`, a noise fraction of at
/// least zero.
pub fn check_recording(speed: f64, rate: f64, duration: f64, noise_fraction: f64, dt: f64) -> Result<(), String> {
    let positive = [("speed", speed), ("rate", rate), ("duration", duration)];
    if let Some((name, v)) = positive.iter().find(|(_, v)| !(*v > 0.0 && v.is_finite())) {
        return Err(format!("{name} must be positive, got {v}"));
    }
    let steps = 1.0 / (rate * dt);
    if steps < 1.0 || (steps - steps.round()).abs() > 1e-9 * steps {
        return Err(format!("the sample time 1/{rate} s must be a whole number of the truth's {dt} s steps"));
    }
    if !(noise_fraction >= 0.0 && noise_fraction.is_finite()) {
        return Err(format!("the noise fraction must be at least 0, got {noise_fraction}"));
    }
    Ok(())
}

/// The channels with white noise of `fraction` of each one's RMS drawn from `rng`, sample
/// by sample and channel by channel, and the noise's standard deviations.
pub fn with_noise<const N: usize>(
    channels: &[[f64; N]],
    fraction: f64,
    rng: &mut ChaCha8Rng,
) -> (Vec<[f64; N]>, [f64; N]) {
    let n = channels.len().max(1) as f64;
    let mut std = [0.0; N];
    for row in channels {
        for (s, v) in std.iter_mut().zip(row) {
            *s += v * v;
        }
    }
    std = std.map(|s| fraction * (s / n).sqrt());
    let mut noise = SensorNoise::new(rng.clone(), std);
    let noisy = channels.iter().map(|row| noise.measure(*row)).collect();
    // The caller's stream goes on from where the noise left it.
    *rng = noise.into_stream();
    (noisy, std)
}

/// A Blackman-windowed sinc low-pass, linear phase, unit gain at DC: it passes up to 0.4
/// of the output rate (within 0.01 dB) and stops from 0.5 of it (below −70 dB).
#[derive(Debug, Clone, PartialEq)]
pub struct AntiAlias {
    /// Symmetric taps, an odd number of them.
    taps: Vec<f64>,
}

impl AntiAlias {
    /// The filter for a signal sampled every `dt` seconds that is decimated to `rate` Hz.
    pub fn new(dt: f64, rate: f64) -> Self {
        // The cut-off in the middle of the transition band from 0.4·rate to 0.5·rate, whose
        // width sets the length: a Blackman window's transition is 5.5 / length.
        let cutoff = 0.45 * rate * dt;
        let half = (5.5 / (0.1 * rate * dt) / 2.0).ceil() as usize;
        let length = 2 * half + 1;
        let mut taps: Vec<f64> = (0..length)
            .map(|n| {
                let x = n as f64 - half as f64;
                let sinc = if x == 0.0 { 2.0 * cutoff } else { math::sin(2.0 * PI * cutoff * x) / (PI * x) };
                let phase = 2.0 * PI * n as f64 / (length - 1) as f64;
                sinc * (0.42 - 0.5 * math::cos(phase) + 0.08 * math::cos(2.0 * phase))
            })
            .collect();
        let sum: f64 = taps.iter().sum();
        taps.iter_mut().for_each(|t| *t /= sum);
        Self { taps }
    }

    /// How many input samples the filter reaches on either side of its centre.
    pub fn half_length(&self) -> usize {
        self.taps.len() / 2
    }

    /// The filtered signal at input index `k`, the signal given by `value(i)` for
    /// `i ≤ k + half_length()`; before its start it is held at its first value (the run
    /// starts at rest).
    pub fn at(&self, k: usize, value: impl Fn(usize) -> f64) -> f64 {
        let half = self.half_length();
        self.taps.iter().enumerate().map(|(j, t)| t * value((k + j).saturating_sub(half))).sum()
    }

    /// The gain at `frequency` (Hz) for an input sampled every `dt`: the filter is
    /// symmetric, so its response is real.
    pub fn gain(&self, frequency: f64, dt: f64) -> f64 {
        let half = self.half_length() as f64;
        let w = 2.0 * PI * frequency * dt;
        self.taps.iter().enumerate().map(|(n, t)| t * math::cos(w * (n as f64 - half))).sum::<f64>().abs()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const DT: f64 = 1e-4;

    #[test]
    fn it_passes_the_band_and_stops_what_would_fold_into_it() {
        for rate in [200.0, 1000.0] {
            let daq = AntiAlias::new(DT, rate);
            for f in [0.0, 0.1 * rate, 0.25 * rate, 0.4 * rate] {
                let db = 20.0 * math::log10(daq.gain(f, DT));
                assert!(db.abs() < 0.01, "{rate} Hz: {db} dB at {f} Hz");
            }
            for f in [0.5 * rate, 0.6 * rate, rate, 2.2 * rate, 4.0 * rate] {
                let db = 20.0 * math::log10(daq.gain(f, DT));
                assert!(db < -70.0, "{rate} Hz: {db} dB at {f} Hz");
            }
        }
    }

    #[test]
    fn a_tone_above_half_the_rate_does_not_reach_the_samples_and_one_below_keeps_its_phase() {
        let daq = AntiAlias::new(DT, 200.0);
        // 222 Hz, the weld's short wave at 80 km/h: point sampling at 200 Hz would read it as 22 Hz.
        let fast = |i: usize| math::sin(2.0 * PI * 222.0 * i as f64 * DT);
        let slow = |i: usize| math::sin(2.0 * PI * 30.0 * i as f64 * DT + 0.3);
        for k in (5_000..6_000).step_by(50) {
            assert!(daq.at(k, fast).abs() < 1e-3, "{}", daq.at(k, fast));
            // Centred, so no delay: the sample is the tone's value at its own instant.
            assert!((daq.at(k, slow) - slow(k)).abs() < 2e-3, "{} vs {}", daq.at(k, slow), slow(k));
        }
    }

    #[test]
    fn a_signal_at_rest_before_the_start_stays_at_rest() {
        let daq = AntiAlias::new(DT, 1000.0);
        assert_eq!(daq.at(0, |_| 0.0), 0.0);
        assert!((daq.at(3, |_| 2.5) - 2.5).abs() < 1e-12);
    }
}
