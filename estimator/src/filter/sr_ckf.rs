//! The square-root cubature Kalman filter (Arasaratnam & Haykin 2009,
//! Algorithm 2; the paper of study S1, eqs. (9)–(23)). It propagates a
//! lower-triangular `S` with `S·Sᵀ = P` and never forms or factorises `P`:
//!
//! ```text
//! predict:  Xᵢ = x̂ ± √n·S·eⱼ,  Yᵢ = φ(Xᵢ),  x̂⁻ = Σ Yᵢ/2n
//!           S⁻ = Tria([Y*, S_Q]),            Y* = [Yᵢ − x̂⁻]/√(2n)
//! update:   Xᵢ = x̂⁻ ± √n·S⁻·eⱼ,  Zᵢ = h(Xᵢ),  ẑ = Σ Zᵢ/2n
//!           γ = [Zᵢ − ẑ]/√(2n),  χ = [Xᵢ − x̂⁻]/√(2n)
//!           S_zz = Tria([γ, S_R]),  P_xz = χ·γᵀ
//!           W = (P_xz / S_zzᵀ) / S_zz           (two triangular solves)
//!           x̂ = x̂⁻ + W·(z − ẑ),  S = Tria([χ − W·γ, W·S_R])
//! ```
//!
//! `Tria` is a Householder QR (see `linalg/tria.rs`). The compound matrices are
//! built transposed, one row per point, so that the QR runs down contiguous
//! columns. `S_Q` is lower triangular (see [`Noise`]), so the predict compound
//! `[S_Q, Y*]ᵀ` has an upper-triangular top block that the QR exploits.

use nalgebra::{DMatrix, DVector};

use crate::error::{FilterError, Stage};
use crate::filter::core::{core_accessors, ensure_finite, Core};
use crate::filter::{FilterKind, Innovation, StateEstimator};
use crate::gaussian::Gaussian;
#[cfg(target_arch = "x86_64")]
use crate::linalg::Avx2;
use crate::linalg::{axpy, lower_gram, solve_lower, solve_right_lower, solve_right_lower_transposed, Tria};
use crate::model::Model;
use crate::noise::{lower_square_root, Noise};

/// SRCKF. Keeps running where rounding would make the CKF's `P` indefinite.
#[derive(Debug, Clone)]
pub struct SquareRootCubature<M> {
    core: Core<M>,
    /// `S`, lower triangular with a non-negative diagonal.
    s: DMatrix<f64>,
    s_next: DMatrix<f64>,
    /// Points (`n × 2n`).
    xs: DMatrix<f64>,
    /// Propagated points (`n × 2n`).
    ys: DMatrix<f64>,
    /// `[S_Q, Y*]ᵀ` (`3n × n`, upper-triangular top).
    predict_compound: Tria,
    /// `[χ − W·γ, W·S_R]ᵀ` (`(2n + m) × n`).
    update_compound: Tria,
    /// Measurement points on the used rows (`m × 2n`).
    zs: DMatrix<f64>,
    z_point: DVector<f64>,
    z_hat: DVector<f64>,
    /// `γᵀ` (`2n × m`, first `mv` columns used).
    gamma_t: DMatrix<f64>,
    /// `[γ, S_R]ᵀ` (`(2n + m) × m`).
    zz_compound: Tria,
    /// `S_zz` (`m × m`, top-left `mv × mv` used).
    s_zz: DMatrix<f64>,
    /// `S_R` restricted to the used rows (`m × m`, top `mv` rows used).
    s_r_used: DMatrix<f64>,
    /// `P_xz`, then the gain `W` (`n × m`, first `mv` columns used).
    gain: DMatrix<f64>,
    /// `W·S_R,used` (`n × m`).
    w_s_r: DMatrix<f64>,
    nu: DVector<f64>,
    e: DVector<f64>,
    s_innovation: DMatrix<f64>,
}

impl<M: Model> SquareRootCubature<M> {
    /// An SRCKF starting from `prior` at time 0. `P₀` may be singular
    /// (positive semi-definite); its square root comes from an eigen-decomposition.
    pub fn new(model: M, noise: Noise, prior: &Gaussian) -> Result<Self, FilterError> {
        let core = Core::new(model, noise, 0.0, prior)?;
        let (n, m) = (core.n(), core.m());
        let mut filter = Self {
            s: DMatrix::zeros(n, n),
            s_next: DMatrix::zeros(n, n),
            xs: DMatrix::zeros(n, 2 * n),
            ys: DMatrix::zeros(n, 2 * n),
            predict_compound: Tria::upper_on_top(3 * n, n),
            update_compound: Tria::dense(2 * n + m, n),
            zs: DMatrix::zeros(m, 2 * n),
            z_point: DVector::zeros(m),
            z_hat: DVector::zeros(m),
            gamma_t: DMatrix::zeros(2 * n, m),
            zz_compound: Tria::dense(2 * n + m, m),
            s_zz: DMatrix::zeros(m, m),
            s_r_used: DMatrix::zeros(m, m),
            gain: DMatrix::zeros(n, m),
            w_s_r: DMatrix::zeros(n, m),
            nu: DVector::zeros(m),
            e: DVector::zeros(m),
            s_innovation: DMatrix::zeros(m, m),
            core,
        };
        filter.set_sqrt_from(&prior.covariance)?;
        Ok(filter)
    }

    /// The model.
    pub fn model(&self) -> &M {
        &self.core.model
    }

    /// The model, to change its parameters between steps.
    pub fn model_mut(&mut self) -> &mut M {
        &mut self.core.model
    }

    /// `S ← Tria(root(P₀))`: a triangular square root of a PSD matrix.
    fn set_sqrt_from(&mut self, p0: &DMatrix<f64>) -> Result<(), FilterError> {
        let n = self.core.n();
        let root = lower_square_root("initial covariance", p0)?;
        debug_assert_eq!(root.nrows(), n);
        self.s.copy_from(&root);
        Ok(())
    }

    /// Spreads `xs = x̂ ± √n·S·eⱼ`.
    #[inline(always)]
    fn spread(&mut self) {
        let n = self.core.n();
        let c = (n as f64).sqrt();
        let x = self.core.x.as_slice();
        let (plus, minus) = self.xs.as_mut_slice().split_at_mut(n * n);
        let columns = self.s.as_slice().chunks_exact(n).zip(plus.chunks_exact_mut(n).zip(minus.chunks_exact_mut(n)));
        for (col, (p, m)) in columns {
            for (((p, m), xi), si) in p.iter_mut().zip(m.iter_mut()).zip(x).zip(col) {
                *p = xi + c * si;
                *m = xi - c * si;
            }
        }
    }

    /// The time update (compiled once portable and once with AVX2, see `predict`).
    #[inline(always)]
    fn predict_body(&mut self, u: &[f64], dt: f64) -> Result<(), FilterError> {
        self.core.begin_predict(u, dt)?;
        self.spread();
        let n = self.core.n();
        let t = self.core.t;
        let points = self.xs.as_slice().chunks_exact(n).zip(self.ys.as_mut_slice().chunks_exact_mut(n));
        for (x, y) in points {
            self.core.model.transition(t, dt, x, self.core.u.as_slice(), y);
        }
        ensure_finite(self.ys.as_slice(), Stage::Predict, "propagated cubature points")?;
        let x_next = self.core.x_next.as_mut_slice();
        x_next.fill(0.0);
        let w = 0.5 / n as f64;
        for col in self.ys.as_slice().chunks_exact(n) {
            axpy(w, col, x_next);
        }
        // Column r of the transposed compound (row r of [S_Q, Y*]): S_Q's row r
        // (zero beyond r), then (Yᵢ − x̂⁻)ᵣ/√(2n).
        let scale = w.sqrt();
        let ys = self.ys.as_slice();
        let sq = self.core.noise.q_sqrt().as_slice();
        for (r, &x_r) in x_next.iter().enumerate() {
            let col = self.predict_compound.column_mut(r);
            let (head, points) = col.split_at_mut(n);
            for (k, c) in head[..=r].iter_mut().enumerate() {
                *c = sq[k * n + r];
            }
            for (c, y) in points.iter_mut().zip(ys.chunks_exact(n)) {
                *c = (y[r] - x_r) * scale;
            }
        }
        self.predict_compound.factor(n, self.s_next.as_mut_slice(), n);
        ensure_finite(self.s_next.as_slice(), Stage::Predict, "predicted square-root covariance S")?;
        std::mem::swap(&mut self.core.x, &mut self.core.x_next);
        std::mem::swap(&mut self.s, &mut self.s_next);
        self.core.t = t + dt;
        Ok(())
    }

    /// The measurement update (compiled once portable and once with AVX2).
    #[inline(always)]
    fn update_body(&mut self, z: &[f64]) -> Result<(), FilterError> {
        let mv = self.core.begin_update(z)?;
        if mv == 0 {
            self.core.innovation.record_none();
            return Ok(());
        }
        self.spread();
        let (n, m) = (self.core.n(), self.core.m());
        let n_pts = 2 * n;
        let scale = (0.5 / n as f64).sqrt();
        let rows = self.core.innovation.rows();

        // Measurement points on the used rows (`zs`, one column per point), their mean ẑ, and γᵀ.
        let points = self.xs.as_slice().chunks_exact(n).zip(self.zs.as_mut_slice().chunks_exact_mut(m));
        for (x, z_used) in points {
            let z_point = self.z_point.as_mut_slice();
            self.core.model.observe(self.core.t, x, self.core.u.as_slice(), z_point);
            for (zu, &row) in z_used.iter_mut().zip(rows) {
                *zu = z_point[row];
            }
        }
        let zs = self.zs.as_slice();
        let used = zs.chunks_exact(m).flat_map(|z_used| &z_used[..mv]);
        ensure_finite(used, Stage::Update, "measurement cubature points")?;
        let z_hat = &mut self.z_hat.as_mut_slice()[..mv];
        z_hat.fill(0.0);
        for z_used in zs.chunks_exact(m) {
            axpy(1.0 / n_pts as f64, &z_used[..mv], z_hat);
        }
        let gamma_t = self.gamma_t.as_mut_slice();
        for (a, (g, zh)) in gamma_t.chunks_exact_mut(n_pts).zip(z_hat.iter()).enumerate() {
            for (gi, z_used) in g.iter_mut().zip(zs.chunks_exact(m)) {
                *gi = (z_used[a] - zh) * scale;
            }
        }
        let gamma_t = self.gamma_t.as_slice();

        // S_R on the used rows, and S_zz = Tria([γ, S_R]).
        let s_r = self.core.noise.r_sqrt();
        for k in 0..m {
            for (a, &row) in rows.iter().enumerate() {
                self.s_r_used[(a, k)] = s_r[(row, k)];
            }
        }
        for a in 0..mv {
            let col = self.zz_compound.column_mut(a);
            col[..n_pts].copy_from_slice(&gamma_t[a * n_pts..(a + 1) * n_pts]);
            for k in 0..m {
                col[n_pts + k] = self.s_r_used[(a, k)];
            }
        }
        self.zz_compound.factor(mv, self.s_zz.as_mut_slice(), m);

        // P_xz, then W = P_xz·S_zz⁻ᵀ·S_zz⁻¹ by two triangular solves from the
        // right. For cubature points χ = [Xᵢ − x̂⁻]/√(2n) = [S, −S]/√2, so
        // P_xz = χ·γᵀ = S·Dᵀ/√2 with D = γ[:, ..n] − γ[:, n..]: a triangular
        // product, a quarter of the work of χ·γᵀ.
        let s = self.s.as_slice();
        let gain = self.gain.as_mut_slice();
        for (a, p_a) in gain.chunks_exact_mut(n).take(mv).enumerate() {
            let g = &gamma_t[a * n_pts..(a + 1) * n_pts];
            p_a.fill(0.0);
            for j in 0..n {
                let d = (g[j] - g[n + j]) * std::f64::consts::FRAC_1_SQRT_2;
                axpy(d, &s[j * n + j..(j + 1) * n], &mut p_a[j..]);
            }
        }
        let s_zz = self.s_zz.as_slice();
        let solved =
            solve_right_lower_transposed(s_zz, m, mv, gain, n, n) && solve_right_lower(s_zz, m, mv, gain, n, n);
        if !solved {
            return Err(FilterError::NotPositiveDefinite {
                stage: Stage::Update,
                matrix: "innovation covariance S_zz",
            });
        }

        // x̂ = x̂⁻ + W·ν, and e = S_zz⁻¹·ν for the NIS.
        for (a, &row) in rows.iter().enumerate() {
            self.nu[a] = z[row] - z_hat[a];
            self.e[a] = self.nu[a];
        }
        solve_lower(s_zz, m, mv, self.e.as_mut_slice(), m, 1);
        let gain = self.gain.as_slice();
        let x_next = self.core.x_next.as_mut_slice();
        x_next.copy_from_slice(self.core.x.as_slice());
        for (w_a, &nu_a) in gain.chunks_exact(n).zip(&self.nu.as_slice()[..mv]) {
            axpy(nu_a, w_a, x_next);
        }

        // W·S_R,used, column by column (S_R is lower triangular, often diagonal:
        // its zeros are skipped).
        let w_s_r = self.w_s_r.as_mut_slice();
        for (k, out) in w_s_r.chunks_exact_mut(n).enumerate() {
            out.fill(0.0);
            for (a, w_a) in gain.chunks_exact(n).take(mv).enumerate() {
                let r = self.s_r_used[(a, k)];
                if r != 0.0 {
                    axpy(r, w_a, out);
                }
            }
        }
        let w_s_r = self.w_s_r.as_slice();

        // S = Tria([χ − W·γ, W·S_R]): column q of the transposed compound is
        // χ's row q minus γᵀ·(W's row q), then (W·S_R,used)'s row q.
        for q in 0..n {
            let (top, bottom) = self.update_compound.column_mut(q).split_at_mut(n_pts);
            let (plus, minus) = top.split_at_mut(n);
            for (j, (p, mi)) in plus.iter_mut().zip(minus.iter_mut()).enumerate() {
                let v = s[j * n + q] * std::f64::consts::FRAC_1_SQRT_2;
                *p = v;
                *mi = -v;
            }
            for a in 0..mv {
                axpy(-gain[a * n + q], &gamma_t[a * n_pts..(a + 1) * n_pts], top);
            }
            for (k, v) in bottom.iter_mut().enumerate() {
                *v = w_s_r[k * n + q];
            }
        }
        self.update_compound.factor(n, self.s_next.as_mut_slice(), n);
        ensure_finite(self.core.x_next.as_slice(), Stage::Update, "updated state")?;
        ensure_finite(self.s_next.as_slice(), Stage::Update, "updated square-root covariance S")?;

        // Diagnostics: S_innovation = S_zz·S_zzᵀ on the used rows.
        lower_gram(self.s_zz.as_slice(), m, mv, self.s_innovation.as_mut_slice(), m);
        self.core.innovation.record(
            z_hat,
            self.nu.as_slice(),
            self.s_innovation.as_slice(),
            m,
            self.s_zz.as_slice(),
            m,
            self.e.as_slice(),
        );
        std::mem::swap(&mut self.core.x, &mut self.core.x_next);
        std::mem::swap(&mut self.s, &mut self.s_next);
        Ok(())
    }
}

impl<M: Model> StateEstimator for SquareRootCubature<M> {
    core_accessors!();

    fn kind(&self) -> FilterKind {
        FilterKind::SrCkf
    }

    fn predict(&mut self, u: &[f64], dt: f64) -> Result<(), FilterError> {
        #[cfg(target_arch = "x86_64")]
        if let Some(avx2) = Avx2::detect() {
            #[target_feature(enable = "avx2")]
            fn run<M: Model>(f: &mut SquareRootCubature<M>, _: Avx2, u: &[f64], dt: f64) -> Result<(), FilterError> {
                f.predict_body(u, dt)
            }
            #[allow(unsafe_code)]
            // SAFETY: `avx2` exists, so the CPU has AVX2.
            return unsafe { run(self, avx2, u, dt) };
        }
        self.predict_body(u, dt)
    }

    fn update(&mut self, z: &[f64]) -> Result<&Innovation, FilterError> {
        #[cfg(target_arch = "x86_64")]
        if let Some(avx2) = Avx2::detect() {
            #[target_feature(enable = "avx2")]
            fn run<M: Model>(f: &mut SquareRootCubature<M>, _: Avx2, z: &[f64]) -> Result<(), FilterError> {
                f.update_body(z)
            }
            #[allow(unsafe_code)]
            // SAFETY: `avx2` exists, so the CPU has AVX2.
            unsafe {
                run(self, avx2, z)?
            };
            return Ok(&self.core.innovation);
        }
        self.update_body(z)?;
        Ok(&self.core.innovation)
    }

    fn write_covariance(&self, out: &mut DMatrix<f64>) {
        let n = self.core.n();
        lower_gram(self.s.as_slice(), n, n, out.as_mut_slice(), n);
    }

    fn variance(&self, i: usize) -> f64 {
        (0..=i).map(|k| self.s[(i, k)].powi(2)).sum()
    }

    fn sqrt_covariance(&self) -> Option<&DMatrix<f64>> {
        Some(&self.s)
    }

    fn snapshot(&self) -> crate::filter::Snapshot {
        self.core.snapshot(FilterKind::SrCkf, &self.s)
    }

    fn restore(&mut self, snapshot: &crate::filter::Snapshot) -> Result<(), FilterError> {
        let covariance = self.core.restore(FilterKind::SrCkf, snapshot)?;
        self.s.copy_from_slice(covariance);
        Ok(())
    }

    fn reset(&mut self, t0: f64, prior: &Gaussian) -> Result<(), FilterError> {
        self.core.reset(t0, prior)?;
        self.set_sqrt_from(&prior.covariance)
    }
}
