//! One rail of a ballasted track (Zhai's vertical model) under a moving vehicle: the rail
//! an Euler–Bernoulli beam on discrete fastener supports, by modal superposition; under
//! each support a sleeper and a ballast block on springs and dampers, neighbouring ballast
//! blocks coupled in shear; the subgrade fixed.
//!
//! **A window that moves with the vehicle.** The modelled rail is a simply supported beam
//! of `supports` sleeper spacings whose middle follows the car body: each time the vehicle
//! advances one spacing, the window moves on by one. The sleepers and ballast blocks shift
//! by one (the one left behind is dropped; the new one ahead starts at rest) and the rail's
//! shape is re-expanded on the modes of the moved window (`q ← T·q`, with `T` the modes'
//! overlap after a shift of one spacing; the stretch that enters ahead starts undeflected).
//! The re-expansion loses only what the modes cannot represent, provided the rail that
//! leaves the window behind is at rest: 100 spacings (60 m) leave 20 m of rail on either
//! side of a 20.4 m wheel span, where a static deflection decays as `e^{−βx}` with
//! β = 1.15 /m (Winkler) to below 1e-9 of its peak.
//!
//! **Modes.** `Z_k(x) = √(2/(m_r·L))·sin(kπx/L)`, mass-normalised; 100 modes of a 60 m
//! window reach 1.44 kHz, above the P2 resonance (35–55 Hz), the sleeper-passing frequency
//! (37 Hz at 80 km/h), the short weld wave (222 Hz) and the pinned–pinned mode (about
//! 1 kHz), and below the 1/(πΔt) ≈ 3.2 kHz that the explicit step of 1e-4 s resolves.

use estimator::math;
use nalgebra::{DMatrix, DVector};

use super::parameters::Track;

/// The rail's modes and supports, precomputed.
#[derive(Debug, Clone)]
pub struct TrackModel {
    /// The track's data.
    pub track: Track,
    /// Rail modes.
    pub modes: usize,
    /// Sleepers (and ballast blocks) in the window.
    pub supports: usize,
    /// Window length (m).
    pub length: f64,
    /// `ω_k²` of each mode (rad²/s²).
    omega2: Vec<f64>,
    /// `Z_k(x_i)`, row `i` (support), column `k` (mode).
    shape_at_support: Vec<f64>,
    /// The modes' overlap after the window moves one spacing on: `q ← T·q`.
    shift: DMatrix<f64>,
}

/// Where the track's degrees of freedom sit in a state vector: rail modes, then sleepers,
/// then ballast blocks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Layout {
    /// Index of the first rail mode.
    pub modes: usize,
    /// Index of the first sleeper.
    pub sleepers: usize,
    /// Index of the first ballast block.
    pub ballast: usize,
    /// Index past the last ballast block.
    pub end: usize,
}

impl TrackModel {
    /// A window of `supports` spacings with `modes` rail modes.
    pub fn new(track: Track, modes: usize, supports: usize) -> Self {
        let length = supports as f64 * track.sleeper_spacing;
        let bending = track.rail_bending_stiffness / track.rail_mass_per_metre;
        let omega2 = (1..=modes).map(|k| bending * (k as f64 * std::f64::consts::PI / length).powi(4)).collect();
        let mut model = Self {
            track,
            modes,
            supports,
            length,
            omega2,
            shape_at_support: Vec::with_capacity(modes * supports),
            shift: DMatrix::zeros(modes, modes),
        };
        let mut shape = vec![0.0; modes];
        for i in 0..supports {
            model.mode_shapes(model.support_position(i), &mut shape);
            model.shape_at_support.extend_from_slice(&shape);
        }
        model.shift = model.shift_matrix();
        model
    }

    /// Position of support `i` in the window (m): half a spacing from the window's start.
    pub fn support_position(&self, i: usize) -> f64 {
        (i as f64 + 0.5) * self.track.sleeper_spacing
    }

    /// The layout of the track's degrees of freedom from index `start` of a state vector.
    pub fn layout(&self, start: usize) -> Layout {
        let sleepers = start + self.modes;
        let ballast = sleepers + self.supports;
        Layout { modes: start, sleepers, ballast, end: ballast + self.supports }
    }

    /// `Z_k(x)` for every mode, `x` in the window (m): the sines by their recurrence.
    pub fn mode_shapes(&self, x: f64, out: &mut [f64]) {
        let norm = (2.0 / (self.track.rail_mass_per_metre * self.length)).sqrt();
        let theta = std::f64::consts::PI * x / self.length;
        let (s1, twice_cos) = (math::sin(theta), 2.0 * math::cos(theta));
        let (mut previous, mut current) = (0.0, s1);
        for z in out.iter_mut().take(self.modes) {
            *z = norm * current;
            (previous, current) = (current, twice_cos * current - previous);
        }
    }

    /// The rail's displacement and velocity at a point of mode shapes `shape`.
    pub fn rail_at(&self, shape: &[f64], u: &[f64], v: &[f64], layout: Layout) -> (f64, f64) {
        let q = &u[layout.modes..layout.sleepers];
        let qd = &v[layout.modes..layout.sleepers];
        shape.iter().zip(q).zip(qd).fold((0.0, 0.0), |(z, zd), ((s, q), qd)| (z + s * q, zd + s * qd))
    }

    /// The track's accelerations into `a` for the state `(u, v)` under the wheel loads
    /// `loads` (N, down) acting at points of mode shapes `wheel_shapes` (one row of `modes`
    /// per wheel).
    pub fn accelerations(
        &self,
        u: &[f64],
        v: &[f64],
        layout: Layout,
        wheel_shapes: &[f64],
        loads: &[f64],
        a: &mut [f64],
    ) {
        let t = &self.track;
        let (m, n) = (self.modes, self.supports);
        let modal = layout.modes..layout.sleepers;
        let (q, qd) = (&u[modal.clone()], &v[modal.clone()]);
        let (zs, zsd) = (&u[layout.sleepers..layout.ballast], &v[layout.sleepers..layout.ballast]);
        let (zb, zbd) = (&u[layout.ballast..layout.end], &v[layout.ballast..layout.end]);
        // Modal forces: the wheels push the rail down.
        let (modal_a, rest) = a[layout.modes..layout.end].split_at_mut(m);
        let (sleeper_a, ballast_a) = rest.split_at_mut(n);
        for (k, f) in modal_a.iter_mut().enumerate() {
            *f = -self.omega2[k] * q[k];
        }
        for (shape, load) in wheel_shapes.chunks_exact(m).zip(loads) {
            for (f, s) in modal_a.iter_mut().zip(shape) {
                *f += load * s;
            }
        }
        for i in 0..n {
            let shape = &self.shape_at_support[i * m..(i + 1) * m];
            let (mut zr, mut zrd) = (0.0, 0.0);
            for ((s, q), qd) in shape.iter().zip(q).zip(qd) {
                zr += s * q;
                zrd += s * qd;
            }
            let pad = t.pad_stiffness * (zr - zs[i]) + t.pad_damping * (zrd - zsd[i]);
            // The pad holds the rail up.
            for (f, s) in modal_a.iter_mut().zip(shape) {
                *f -= pad * s;
            }
            let ballast = t.ballast_stiffness * (zs[i] - zb[i]) + t.ballast_damping * (zsd[i] - zbd[i]);
            sleeper_a[i] = (pad - ballast) / t.sleeper_mass;
            let (left, left_d) = if i > 0 { (zb[i - 1], zbd[i - 1]) } else { (0.0, 0.0) };
            let (right, right_d) = if i + 1 < n { (zb[i + 1], zbd[i + 1]) } else { (0.0, 0.0) };
            let shear = t.ballast_shear_stiffness * (2.0 * zb[i] - left - right)
                + t.ballast_shear_damping * (2.0 * zbd[i] - left_d - right_d);
            let subgrade = t.subgrade_stiffness * zb[i] + t.subgrade_damping * zbd[i];
            ballast_a[i] = (ballast - subgrade - shear) / t.ballast_mass;
        }
    }

    /// Moves the window one spacing on, for every vector given (displacements, velocities,
    /// and the integrator's previous accelerations).
    pub fn shift(&self, layout: Layout, vectors: &mut [&mut [f64]]) {
        for x in vectors.iter_mut() {
            let q = DVector::from_column_slice(&x[layout.modes..layout.sleepers]);
            x[layout.modes..layout.sleepers].copy_from_slice((&self.shift * q).as_slice());
            for range in [layout.sleepers..layout.ballast, layout.ballast..layout.end] {
                let block = &mut x[range];
                block.rotate_left(1);
                *block.last_mut().expect("supports") = 0.0;
            }
        }
    }

    /// `T_kl = ∫_0^{L−s} m_r·Z_k(x)·Z_l(x + s) dx`, in closed form.
    fn shift_matrix(&self) -> DMatrix<f64> {
        let (l, s) = (self.length, self.track.sleeper_spacing);
        let x_end = l - s;
        // ∫_0^X cos(αx + φ) dx
        let integral = |alpha: f64, phi: f64| {
            if alpha.abs() < 1e-12 {
                x_end * math::cos(phi)
            } else {
                (math::sin(alpha * x_end + phi) - math::sin(phi)) / alpha
            }
        };
        DMatrix::from_fn(self.modes, self.modes, |k, j| {
            let (a, b) = (std::f64::consts::PI * (k + 1) as f64 / l, std::f64::consts::PI * (j + 1) as f64 / l);
            let c = b * s;
            // sin(ax)·sin(bx + c) = ½[cos((a − b)x − c) − cos((a + b)x + c)], and m_r·Z_k·Z_l = (2/L)·sin·sin.
            (2.0 / l) * 0.5 * (integral(a - b, -c) - integral(a + b, c))
        })
    }

    /// The static deflection of the track under `loads` (N, down) at points of mode shapes
    /// `wheel_shapes`: the displacements of its degrees of freedom, in layout order from 0.
    pub fn static_deflection(&self, wheel_shapes: &[f64], loads: &[f64]) -> Vec<f64> {
        let t = &self.track;
        let (m, n) = (self.modes, self.supports);
        let size = m + 2 * n;
        let mut k = DMatrix::<f64>::zeros(size, size);
        let mut f = DVector::<f64>::zeros(size);
        for mode in 0..m {
            k[(mode, mode)] = self.omega2[mode];
        }
        for i in 0..n {
            let shape = &self.shape_at_support[i * m..(i + 1) * m];
            let (s, b) = (m + i, m + n + i);
            for (r, zr) in shape.iter().enumerate() {
                for (c, zc) in shape.iter().enumerate() {
                    k[(r, c)] += t.pad_stiffness * zr * zc;
                }
                k[(r, s)] -= t.pad_stiffness * zr;
                k[(s, r)] -= t.pad_stiffness * zr;
            }
            k[(s, s)] += t.pad_stiffness + t.ballast_stiffness;
            k[(s, b)] -= t.ballast_stiffness;
            k[(b, s)] -= t.ballast_stiffness;
            k[(b, b)] += t.ballast_stiffness + t.subgrade_stiffness + 2.0 * t.ballast_shear_stiffness;
            if i + 1 < n {
                k[(b, b + 1)] -= t.ballast_shear_stiffness;
                k[(b + 1, b)] -= t.ballast_shear_stiffness;
            }
        }
        for (shape, load) in wheel_shapes.chunks_exact(m).zip(loads) {
            for (r, z) in shape.iter().enumerate() {
                f[r] += load * z;
            }
        }
        let solution = k.lu().solve(&f).expect("the track's stiffness matrix is regular");
        solution.as_slice().to_vec()
    }
}
