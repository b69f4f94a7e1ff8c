//! Welch's power spectral density: the signal cut into segments of
//! `segment` samples overlapping by half, each detrended (mean removed) and
//! Hann-windowed, their periodograms averaged; one-sided, density scaling
//! (units²/Hz) — the same estimate as `scipy.signal.welch` with its defaults
//! (`window='hann'`, `noverlap=segment/2`, `detrend='constant'`, `scaling='density'`).

use std::f64::consts::PI;

use rustfft::num_complex::Complex;
use rustfft::FftPlanner;

/// A one-sided spectrum.
#[derive(Debug, Clone, PartialEq)]
pub struct Spectrum {
    /// Frequencies (Hz), `0 … fs/2`.
    pub frequency: Vec<f64>,
    /// Power spectral density (unit²/Hz).
    pub density: Vec<f64>,
}

/// Welch's PSD of `x` sampled at `fs` Hz with segments of `segment` samples
/// (reduced to the signal length if it is shorter).
pub fn welch(x: &[f64], fs: f64, segment: usize) -> Spectrum {
    let [spectrum, _] = welch_pair(x, x, fs, segment);
    spectrum
}

/// Welch's PSDs of two signals sampled together (a truth and its estimate), over their
/// common length: each equal to [`welch`]'s, at the cost of one complex FFT per segment for
/// both. The segments go in as `x + i·y`; since both are real, `X_k = (Z_k + Z*_{N−k})/2`
/// and `Y_k = (Z_k − Z*_{N−k})/(2i)`.
pub fn welch_pair(x: &[f64], y: &[f64], fs: f64, segment: usize) -> [Spectrum; 2] {
    let len = x.len().min(y.len());
    let n = segment.min(len).max(2);
    let step = n - n / 2;
    // scipy's periodic Hann window (sym=False).
    let window: Vec<f64> = (0..n).map(|i| 0.5 - 0.5 * (2.0 * PI * i as f64 / n as f64).cos()).collect();
    let scale = 1.0 / (fs * window.iter().map(|w| w * w).sum::<f64>());
    let fft = FftPlanner::new().plan_fft_forward(n);
    let bins = n / 2 + 1;
    let mut density = [vec![0.0; bins], vec![0.0; bins]];
    let mut buffer = vec![Complex::new(0.0, 0.0); n];
    let mut segments = 0;
    let mut start = 0;
    while start + n <= len {
        let (sx, sy) = (&x[start..start + n], &y[start..start + n]);
        let (mx, my) = (sx.iter().sum::<f64>() / n as f64, sy.iter().sum::<f64>() / n as f64);
        for (((b, u), v), w) in buffer.iter_mut().zip(sx).zip(sy).zip(&window) {
            *b = Complex::new((u - mx) * w, (v - my) * w);
        }
        fft.process(&mut buffer);
        for k in 0..bins {
            let (z, z_mirror) = (buffer[k], buffer[(n - k) % n].conj());
            density[0][k] += ((z + z_mirror) * 0.5).norm_sqr() * scale;
            density[1][k] += ((z - z_mirror) * Complex::new(0.0, -0.5)).norm_sqr() * scale;
        }
        segments += 1;
        start += step;
    }
    let segments = segments.max(1) as f64;
    for d in &mut density {
        for (k, d) in d.iter_mut().enumerate() {
            *d /= segments;
            // One-sided: double everything but DC and (for even n) Nyquist.
            if k != 0 && !(n.is_multiple_of(2) && k == n / 2) {
                *d *= 2.0;
            }
        }
    }
    let frequency: Vec<f64> = (0..bins).map(|k| k as f64 * fs / n as f64).collect();
    let [dx, dy] = density;
    [Spectrum { frequency: frequency.clone(), density: dx }, Spectrum { frequency, density: dy }]
}

/// The widest run of frequency bins above DC in which two spectra agree
/// within `db` decibels; `None` if no bin does.
pub fn agreement_band(a: &Spectrum, b: &Spectrum, db: f64) -> Option<(f64, f64)> {
    let within = |k: usize| {
        let (x, y) = (a.density[k], b.density[k]);
        x > 0.0 && y > 0.0 && (10.0 * (x / y).log10()).abs() <= db
    };
    let mut best: Option<(usize, usize)> = None;
    let mut run_start = None;
    for k in 1..=a.density.len().min(b.density.len()) {
        let inside = k < a.density.len().min(b.density.len()) && within(k);
        match (inside, run_start) {
            (true, None) => run_start = Some(k),
            (false, Some(s)) => {
                if best.is_none_or(|(bs, be)| k - 1 - s > be - bs) {
                    best = Some((s, k - 1));
                }
                run_start = None;
            }
            _ => {}
        }
    }
    best.map(|(s, e)| (a.frequency[s], a.frequency[e]))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_sine_puts_its_power_at_its_frequency_and_parseval_holds() {
        let fs = 200.0;
        let x: Vec<f64> = (0..20_000).map(|k| 3.0 * (2.0 * PI * 12.5 * k as f64 / fs).sin()).collect();
        let s = welch(&x, fs, 256);
        let peak = s.density.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1)).unwrap().0;
        assert!((s.frequency[peak] - 12.5).abs() < fs / 256.0);
        // The integral of the PSD is the variance, 3²/2.
        let df = s.frequency[1];
        let power: f64 = s.density.iter().sum::<f64>() * df;
        assert!((power - 4.5).abs() < 0.05 * 4.5, "power {power}");
    }

    #[test]
    fn a_pair_gives_each_signals_own_spectrum() {
        let fs = 100.0;
        let x: Vec<f64> = (0..5000).map(|k| (2.0 * PI * 3.0 * k as f64 / fs).sin() + 0.5).collect();
        let y: Vec<f64> = (0..5000).map(|k| ((k * 7919) % 101) as f64 / 50.0 - 1.0).collect();
        let [px, py] = welch_pair(&x, &y, fs, 256);
        for (pair, x) in [(&px, &x), (&py, &y)] {
            // The one-signal estimate, computed directly: a real FFT per segment.
            let n = 256;
            let window: Vec<f64> = (0..n).map(|i| 0.5 - 0.5 * (2.0 * PI * i as f64 / n as f64).cos()).collect();
            let scale = 1.0 / (fs * window.iter().map(|w| w * w).sum::<f64>());
            let fft = FftPlanner::new().plan_fft_forward(n);
            let mut direct = vec![0.0; n / 2 + 1];
            let mut segments = 0.0;
            for start in (0..=x.len() - n).step_by(n / 2) {
                let seg = &x[start..start + n];
                let mean = seg.iter().sum::<f64>() / n as f64;
                let mut b: Vec<Complex<f64>> =
                    seg.iter().zip(&window).map(|(v, w)| Complex::new((v - mean) * w, 0.0)).collect();
                fft.process(&mut b);
                direct.iter_mut().zip(&b).for_each(|(d, b)| *d += b.norm_sqr() * scale);
                segments += 1.0;
            }
            // Rounding in the shared FFT is relative to the largest bin of either signal.
            let peak = direct.iter().copied().fold(0.0, f64::max) / segments * 2.0;
            for (k, (p, d)) in pair.density.iter().zip(&direct).enumerate() {
                let d = d / segments * if k == 0 || k == n / 2 { 1.0 } else { 2.0 };
                assert!((p - d).abs() <= 1e-13 * peak, "bin {k}: {p} vs {d}");
            }
        }
    }

    #[test]
    fn identical_spectra_agree_over_every_bin() {
        let x: Vec<f64> = (0..4096).map(|k| ((k * 7919) % 101) as f64).collect();
        let s = welch(&x, 100.0, 256);
        let (lo, hi) = agreement_band(&s, &s, 3.0).unwrap();
        assert_eq!((lo, hi), (s.frequency[1], *s.frequency.last().unwrap()));
    }
}
