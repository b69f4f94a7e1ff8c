//! The most any vertical model can give of the sides: each wheelset's `F_L + F_R` and
//! `F_L − F_R` from its own bounce and roll equations, fed with the truth's noise-free
//! vertical motion (both axle boxes' accelerations, the primary deflections and their
//! rates) and the car's true vertical data. What is left between them and the true forces
//! is what a vertical model leaves out: the lateral creep forces at rail height (`r0·ΣH`),
//! the contact points' shift with the wheelset's lateral displacement (`y·ΣN`) and the
//! lean of the normal forces on the cones. A filter on these equations, however tuned, does
//! not separate the sides better than this; it measures how far the lateral dynamics
//! limit them, case by case.

use truth::s2::vehicle::VehicleModel;
use truth::s3::cases::{Truth, ACCELERATIONS, DEFLECTIONS};
use truth::s3::parameters::Vehicle;

use super::study::{forces_in_model_order, in_model_order};

/// One wheelset's ceiling: the correlations of its forces, sum and difference, so
/// reconstructed, with the truth's.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Ceiling {
    /// Of `F_L`.
    pub left_correlation: f64,
    /// Of `F_R`.
    pub right_correlation: f64,
    /// Of `F_L + F_R`: near 1, a check that the equations are the truth's vertical ones.
    pub sum_correlation: f64,
    /// Of `F_L − F_R`.
    pub difference_correlation: f64,
}

/// Each wheelset's ceiling over the samples from `settle` seconds on, for `truth` recorded
/// at `rate` (Hz) on the car `vehicle` (the one that ran).
pub fn ceiling(truth: &Truth, vehicle: &Vehicle, rate: f64, settle: f64) -> [Ceiling; 4] {
    let v = &vehicle.vertical;
    // The truth's own damper law, odd in the rate: compression or extension alike.
    let primary = VehicleModel { vehicle: *v };
    let (mass, inertia) = (v.wheelset_mass, vehicle.wheelset_roll_inertia);
    let (dw, a0, weight) = (vehicle.primary_half_span, vehicle.contact_half_span, vehicle.static_wheel_load());
    let n = truth.time.len();
    let first = ((settle * rate).round() as usize).clamp(1, n.saturating_sub(1));
    // The rows of the model's order: left and right per wheelset.
    let accelerations: Vec<[f64; 20]> =
        truth.accelerations.iter().map(|a| in_model_order(&ACCELERATIONS, a, 0)).collect();
    let deflections: Vec<[f64; 8]> = truth.deflections.iter().map(|d| in_model_order(&DEFLECTIONS, d, 20)).collect();
    std::array::from_fn(|j| {
        // Each signal's truth and reconstruction: left, right, sum, difference.
        let mut signals: [(Vec<f64>, Vec<f64>); 4] = Default::default();
        for k in first..n - 1 {
            // Compression rate by central difference: the record is band-limited.
            let spring = |s: usize| {
                let d = deflections[k][2 * j + s];
                let rate_k = (deflections[k + 1][2 * j + s] - deflections[k - 1][2 * j + s]) * rate / 2.0;
                v.primary_stiffness * d + primary.primary_damper(rate_k)
            };
            let (left, right) = (accelerations[k][2 * j], accelerations[k][2 * j + 1]);
            let (bounce, roll) = ((left + right) / 2.0, (left - right) / (2.0 * dw));
            let (f_left, f_right) = (spring(0), spring(1));
            // The estimator's equations (`WheelRailRoll`): m·z̈ = F_L + F_R − 2P0 − f_L − f_R,
            // I·φ̈ = a0·(F_L − F_R) − d_w·(f_L − f_R).
            let forces = forces_in_model_order(&truth.contact[k]);
            let (left_true, right_true) = (forces[2 * j], forces[2 * j + 1]);
            let sum = mass * bounce + 2.0 * weight + f_left + f_right;
            let difference = (inertia * roll + dw * (f_left - f_right)) / a0;
            let pairs = [
                (left_true, (sum + difference) / 2.0),
                (right_true, (sum - difference) / 2.0),
                (left_true + right_true, sum),
                (left_true - right_true, difference),
            ];
            for (signal, (t, e)) in signals.iter_mut().zip(pairs) {
                signal.0.push(t);
                signal.1.push(e);
            }
        }
        let [left, right, sum, difference] = signals.map(|(t, e)| analyzer::metrics::correlation(&t, &e));
        Ceiling {
            left_correlation: left,
            right_correlation: right,
            sum_correlation: sum,
            difference_correlation: difference,
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use truth::s3::cases::{simulate, Case, Settings};

    #[test]
    fn the_vertical_equations_give_the_sum_and_the_lateral_dynamics_limit_the_difference() {
        let settings = Settings { duration: 2.0, ..Settings::default() };
        for case in Case::ALL {
            let c = ceiling(&simulate(case, &settings).unwrap(), &settings.vehicle, settings.rate, 0.5);
            for wheelset in c {
                // The sum holds nothing lateral: the equations are the truth's vertical ones.
                assert!(wheelset.sum_correlation > 0.9999, "{case}: {wheelset:?}");
                // The difference holds the lateral forces' moments, which they leave out.
                assert!(wheelset.difference_correlation < 0.999, "{case}: {wheelset:?}");
                assert!(wheelset.difference_correlation > 0.8, "{case}: {wheelset:?}");
            }
        }
    }
}
