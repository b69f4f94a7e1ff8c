//! S5's numbers, each with its source: the missile's force coefficients before and after
//! the mid-flight change (the seed's Tables 1 and 2, "true" columns), its SVD-CKF and CKF
//! figures to print beside ours, and the start of the flight (`docs/studies/s5.md`).

/// The coefficients' names, in the order of eq. (4) and of the estimator's state.
pub const NAMES: [&str; 10] = ["Cx0", "Cx_a", "Cx_b", "Cx_d", "Cy0", "Cy_a", "Cy_d", "Cz0", "Cz_b", "Cz_d"];

/// The true coefficients until the change (Table 1).
pub const BEFORE: [f64; 10] = [-0.2302, 0.1735, 0.3148, 0.3149, -0.0944, 9.2596, -0.8647, 0.5303, -8.7916, 0.2229];

/// The true coefficients after it (Table 2).
pub const AFTER: [f64; 10] = [-0.2878, 0.2041, 0.3703, 0.3499, -0.1049, 9.7469, -0.9608, 0.5892, -9.2543, 0.2477];

/// The paper's SVD-CKF estimates before the change (Table 1).
pub const PAPER_SVD_CKF_BEFORE: [f64; 10] =
    [-0.2319, 0.1750, 0.3176, 0.3211, -0.0953, 9.3369, -0.8727, 0.5344, -8.8658, 0.2216];

/// The paper's SVD-CKF estimates after the change (Table 2).
pub const PAPER_SVD_CKF_AFTER: [f64; 10] =
    [-0.2929, 0.2064, 0.3807, 0.3538, -0.1073, 9.9445, -0.9732, 0.5989, -9.4455, 0.2489];

/// The start: body velocity (1000, 10, 10) m/s, attitude (φ, ψ, γ) = (15°, 3°, 3°), rates
/// 3°/s each (the paper), at 10 km [est: the paper gives no altitude].
pub fn start() -> [f64; 10] {
    let deg = f64::to_radians;
    [1000.0, 10.0, 10.0, deg(15.0), deg(3.0), deg(3.0), 10_000.0, deg(3.0), deg(3.0), deg(3.0)]
}

/// The sensors' noise per measurement (`ωx, ωy, ωz; Nx, Ny, Nz; φ, ψ, γ; h; α, β`), as an
/// instrumented missile has them [est: a tactical-grade IMU and INS, a baro-GPS altitude,
/// an air-data system]: 1e-3 rad/s, 1e-3 g, 1e-3 rad, 1 m, 2e-3 rad.
pub const SENSOR_STD: [f64; 12] = [1e-3, 1e-3, 1e-3, 1e-3, 1e-3, 1e-3, 1e-3, 1e-3, 1e-3, 1.0, 2e-3, 2e-3];
