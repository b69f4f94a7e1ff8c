//! How much a run tells about each coefficient: the Fisher information of one half of the
//! flight (before or after the change) about its ten coefficients and the ten motion
//! states at its start, from the measurements' sensitivities (central differences of the
//! whole noise-free flight) and the sensors' noise; its inverse bounds the variance of any
//! unbiased estimate (Cramér–Rao). A coefficient the manoeuvre leaves unobservable shows
//! as a bound as large as the coefficient.

use nalgebra::{DMatrix, DVector};

use truth::s5::parameters::SENSOR_STD;
use truth::s5::plant::{Flight, Motion};

/// The Cramér–Rao bound (std) of the 20 parameters — the ten motion states at the half's
/// start, then the ten coefficients — over the samples `[first, first + count)` of the
/// flight from `start` (the motion at sample `first`), each sensor's noise scaled by
/// `noise_scale`. `None` if the information matrix is singular.
pub fn cramer_rao(
    flight: &Flight,
    start: &Motion,
    first: usize,
    count: usize,
    sample_time: f64,
    substeps: usize,
    noise_scale: f64,
) -> Option<[f64; 20]> {
    let coefficients = *flight.coefficients_over(first, sample_time);
    let measurements = |x0: &Motion, c: &[f64; 10]| -> Vec<[f64; 12]> {
        let h = sample_time / substeps as f64;
        let mut x = *x0;
        let mut out = Vec::with_capacity(count);
        for k in first..first + count {
            let delta = flight.manoeuvre.held(k, sample_time);
            let mut z = [0.0; 12];
            flight.airframe.measure(&x, c, &delta, &mut z);
            out.push(z);
            for _ in 0..substeps {
                x = flight.step(c, &delta, h, &x);
            }
        }
        out
    };
    // Steps relative to each parameter's scale: small enough for the linearisation, large
    // enough against rounding.
    let scales = [10.0, 10.0, 10.0, 0.01, 0.01, 0.01, 10.0, 0.01, 0.01, 0.01];
    let mut sensitivities: Vec<Vec<[f64; 12]>> = Vec::with_capacity(20);
    for p in 0..20 {
        let (mut x_plus, mut x_minus, mut c_plus, mut c_minus) = (*start, *start, coefficients, coefficients);
        let step = if p < 10 { 1e-4 * scales[p] } else { 1e-4 * coefficients[p - 10].abs().max(0.05) };
        if p < 10 {
            x_plus[p] += step;
            x_minus[p] -= step;
        } else {
            c_plus[p - 10] += step;
            c_minus[p - 10] -= step;
        }
        let (plus, minus) = (measurements(&x_plus, &c_plus), measurements(&x_minus, &c_minus));
        sensitivities.push(
            plus.iter().zip(&minus).map(|(a, b)| std::array::from_fn(|i| (a[i] - b[i]) / (2.0 * step))).collect(),
        );
    }
    // Σ over the samples and the sensors of sₚ·s_q / σ².
    let weights = SENSOR_STD.map(|s| 1.0 / (noise_scale * s).powi(2));
    let information = DMatrix::from_fn(20, 20, |p, q| {
        let terms = sensitivities[p].iter().zip(&sensitivities[q]);
        terms.map(|(a, b)| (0..12).map(|i| weights[i] * a[i] * b[i]).sum::<f64>()).sum::<f64>()
    });
    // Scaled to unit diagonal before inverting: the parameters span ten orders of magnitude.
    let d = DVector::from_fn(20, |p, _| information[(p, p)].sqrt());
    if d.iter().any(|v| v.is_nan() || *v <= 0.0) {
        return None;
    }
    let scaled = DMatrix::from_fn(20, 20, |i, j| information[(i, j)] / (d[i] * d[j]));
    let inverse = scaled.cholesky()?.inverse();
    Some(std::array::from_fn(|p| inverse[(p, p)].sqrt() / d[p]))
}
