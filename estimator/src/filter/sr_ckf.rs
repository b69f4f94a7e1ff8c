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
//!
//! The update works on the symmetric point pairs. With `γ⁺ⱼ, γ⁻ⱼ` the columns
//! of `γ` for `x̂⁻ ± √n·S·eⱼ`, let `D̃ = (γ⁺ − γ⁻)/√2` and `Σ̃ = (γ⁺ + γ⁻)/√2`
//! (`m × n` each). Rotating each column pair by 45° is orthogonal, so it leaves
//! every `Tria` unchanged in exact arithmetic, and it turns the update into
//!
//! ```text
//!           M = Tria([Σ̃, S_R]),  S_zz = Tria([D̃, M]),  P_xz = S·D̃ᵀ
//!           S = Tria([S − W·D̃, W·M])         (n + m columns instead of 2n + m)
//! ```
//!
//! because `χ = [S, −S]/√2` turns into `[S, 0]`, and `[−W·Σ̃, W·S_R]` has the
//! Gram matrix `W·(Σ̃·Σ̃ᵀ + R)·Wᵀ = (W·M)·(W·M)ᵀ`. The largest QR of the
//! update has half the rows.

use nalgebra::{DMatrix, DVector};

use crate::error::{FilterError, Stage};
use crate::filter::core::{core_accessors, ensure_finite, steps_with_avx2, Core};
use crate::filter::point_blocks::PointBlocks;
use crate::filter::{check_process_noise_factor, check_scale, selected, FilterKind, StateEstimator};
use crate::gaussian::Gaussian;
use crate::linalg::{axpy, lower_gram, solve_lower, solve_right_lower, solve_right_lower_transposed, sum, Lanes, Tria};
use crate::model::Model;
use crate::noise::{lower_square_root, Noise};

/// SRCKF. Keeps running where rounding would make the CKF's `P` indefinite.
#[derive(Debug, Clone)]
pub struct SquareRootCubature<M> {
    core: Core<M>,
    /// `S`, lower triangular with a non-negative diagonal.
    s: DMatrix<f64>,
    /// `Sᵀ`: column `i` is row `i` of `S`, which the points take whole.
    /// `Tria` writes it directly; `S` is its transpose.
    s_t: DMatrix<f64>,
    s_t_next: DMatrix<f64>,
    /// One component of every cubature point, padding included (see `spread`).
    point_row: Vec<f64>,
    /// Coefficients of the linear combinations in the gain's triangular
    /// solves: one per used measurement row (`m`).
    coefficients: Vec<f64>,
    /// The `2n` cubature points.
    xs: PointBlocks,
    /// The propagated points.
    ys: PointBlocks,
    /// `[S_Q, Y*]ᵀ` (`3n × n`, upper-triangular top).
    predict_compound: Tria,
    /// `[S − W·D̃, W·M]ᵀ` (`(n + m) × n`).
    update_compound: Tria,
    /// The measurement points.
    zs: PointBlocks,
    /// The used rows of `zs`, one after the other (`2n` values each, `m` rows).
    z_rows: DVector<f64>,
    /// For the models' point-by-point defaults on blocks (`2n + m`).
    model_scratch: Vec<f64>,
    z_hat: DVector<f64>,
    /// `D̃ᵀ = (γ⁺ − γ⁻)ᵀ/√2` (`n × m`, first `mv` columns used).
    d_t: DMatrix<f64>,
    /// `Σ̃ᵀ = (γ⁺ + γ⁻)ᵀ/√2` (`n × m`, first `mv` columns used).
    sigma_t: DMatrix<f64>,
    /// `[Σ̃, S_R,used]ᵀ` (`(n + m) × m`).
    m_compound: Tria,
    /// `M = Tria([Σ̃, S_R,used])` (`m × m`, top-left `mv × mv` used).
    m_root: DMatrix<f64>,
    /// `[D̃, M]ᵀ` (`(n + m) × m`).
    zz_compound: Tria,
    /// `S_zz` (`m × m`, top-left `mv × mv` used).
    s_zz: DMatrix<f64>,
    /// `P_xz`, then the gain `W` (`n × m`, first `mv` columns used).
    gain: DMatrix<f64>,
    /// `W·M` (`n × m`, first `mv` columns used).
    w_m: DMatrix<f64>,
    /// `−Wᵀ` (`m × n`, first `mv` rows used): column q is row q of −W.
    w_t: DMatrix<f64>,
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
        let xs = PointBlocks::new(n, 2 * n);
        let mut filter = Self {
            s: DMatrix::zeros(n, n),
            s_t: DMatrix::zeros(n, n),
            s_t_next: DMatrix::zeros(n, n),
            point_row: vec![0.0; xs.padded_count()],
            coefficients: vec![0.0; m],
            xs,
            ys: PointBlocks::new(n, 2 * n),
            predict_compound: Tria::upper_on_top(3 * n, n),
            update_compound: Tria::dense(n + m, n),
            zs: PointBlocks::new(m, 2 * n),
            z_rows: DVector::zeros(2 * n * m),
            model_scratch: vec![0.0; 2 * n + m],
            z_hat: DVector::zeros(m),
            d_t: DMatrix::zeros(n, m),
            sigma_t: DMatrix::zeros(n, m),
            m_compound: Tria::dense(n + m, m),
            m_root: DMatrix::zeros(m, m),
            zz_compound: Tria::dense(n + m, m),
            s_zz: DMatrix::zeros(m, m),
            gain: DMatrix::zeros(n, m),
            w_m: DMatrix::zeros(n, m),
            w_t: DMatrix::zeros(m, n),
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
        self.s_t.copy_from(&root.transpose());
        Ok(())
    }

    /// Spreads the points `x̂ + √n·S·eⱼ` (point `j`) and `x̂ − √n·S·eⱼ` (point
    /// `n + j`) into their blocks, component by component: component `r` of
    /// the points is `x̂ᵣ ± √n·(row r of S)`, contiguous in `Sᵀ`. The padding holds `x̂`.
    #[inline(always)]
    fn spread(&mut self) {
        let n = self.core.n();
        let c = (n as f64).sqrt();
        let (x, s_t, row) = (self.core.x.as_slice(), self.s_t.as_slice(), self.point_row.as_mut_slice());
        for (r, (&x_r, s_r)) in x.iter().zip(s_t.chunks_exact(n)).enumerate() {
            let (plus, rest) = row.split_at_mut(n);
            let (minus, padding) = rest.split_at_mut(n);
            for ((p, m), &s) in plus.iter_mut().zip(minus.iter_mut()).zip(s_r) {
                *p = x_r + c * s;
                *m = x_r - c * s;
            }
            padding.fill(x_r);
            self.xs.set_component(r, row);
        }
    }

    /// The time update (compiled once for the baseline CPU and once with AVX2 and FMA, see `steps_with_avx2!`).
    #[inline(always)]
    fn predict_body<L: Lanes>(&mut self, lanes: L, u: &[f64], dt: f64) -> Result<(), FilterError> {
        self.core.begin_predict(u, dt)?;
        self.spread();
        let n = self.core.n();
        let t = self.core.t;
        let u = self.core.u.as_slice();
        for (x, y) in self.xs.blocks().zip(self.ys.blocks_mut()) {
            self.core.model.transition_block(t, dt, x, u, y, &mut self.model_scratch);
        }
        // The padding holds φ(x̂), a value the model gives: checked with the rest.
        ensure_finite(self.ys.values(), Stage::Predict, "propagated cubature points")?;
        // Row r of x̂⁻, and the dense rows of column r of the transposed
        // compound (row r of [S_Q, Y*]): (Yᵢ − x̂⁻)ᵣ/√(2n).
        let w = 0.5 / n as f64;
        let scale = w.sqrt();
        for (r, x_r) in self.core.x_next.as_mut_slice().iter_mut().enumerate() {
            let points = &mut self.predict_compound.column_mut(r)[n..];
            self.ys.copy_component(r, points);
            *x_r = w * sum(points);
            for c in points {
                *c = (*c - *x_r) * scale;
            }
        }
        // Its top block is S_Qᵀ (S_Q's row r, zero beyond r, in column r):
        // one transpose rather than a copy per row.
        let (top, ld) = self.predict_compound.columns_mut();
        lanes.transpose(self.core.noise.q_sqrt().as_slice(), n, n, n, top, ld);
        self.predict_compound.factor_by_rows(n, self.s_t_next.as_mut_slice(), n);
        ensure_finite(self.s_t_next.as_slice(), Stage::Predict, "predicted square-root covariance S")?;
        if let Some(cross) = &mut self.core.cross {
            // Σ (Xᵢ − x̂)(Yᵢ − x̂⁻)ᵀ/2n with Xⱼ, Xₙ₊ⱼ = x̂ ± √n·S·eⱼ: column r is
            // Σⱼ (√n/2n)·(Yⱼ − Yₙ₊ⱼ)ᵣ·S·eⱼ (the mean cancels in the difference).
            let c = 0.5 / (n as f64).sqrt();
            cross.fill(0.0);
            for r in 0..n {
                self.ys.copy_component(r, &mut self.point_row[..2 * n]);
                let column = &mut cross.as_mut_slice()[r * n..(r + 1) * n];
                for j in 0..n {
                    let d = c * (self.point_row[j] - self.point_row[n + j]);
                    axpy(d, &self.s.as_slice()[j * n + j..(j + 1) * n], &mut column[j..]);
                }
            }
        }
        self.commit_factor(lanes);
        std::mem::swap(&mut self.core.x, &mut self.core.x_next);
        self.core.t = t + dt;
        Ok(())
    }

    /// The measurement update (compiled once for the baseline CPU and once with AVX2 and FMA).
    #[inline(always)]
    fn update_body<L: Lanes>(&mut self, lanes: L, z: &[f64]) -> Result<(), FilterError> {
        let mv = self.core.begin_update(z)?;
        if mv == 0 {
            self.core.innovation.record_none();
            return Ok(());
        }
        self.spread();
        let (n, m) = (self.core.n(), self.core.m());
        let rows = self.core.innovation.rows();

        // Measurement points, and the mean ẑ of the used rows.
        let (t, u) = (self.core.t, self.core.u.as_slice());
        for (x, z) in self.xs.blocks().zip(self.zs.blocks_mut()) {
            self.core.model.observe_block(t, x, u, z, &mut self.model_scratch);
        }
        let z_rows = &mut self.z_rows.as_mut_slice()[..mv * 2 * n];
        for (z_row, &row) in z_rows.chunks_exact_mut(2 * n).zip(rows) {
            self.zs.copy_component(row, z_row);
        }
        ensure_finite(z_rows, Stage::Update, "measurement cubature points")?;
        let z_hat = &mut self.z_hat.as_mut_slice()[..mv];
        let w = 0.5 / n as f64;
        for (zh, z_row) in z_hat.iter_mut().zip(z_rows.chunks_exact(2 * n)) {
            *zh = w * sum(z_row);
        }

        // D̃ = (γ⁺ − γ⁻)/√2 and Σ̃ = (γ⁺ + γ⁻)/√2, one column of Dᵀ-shape per used row.
        let c = 0.5 / (n as f64).sqrt();
        let (d_t, sigma_t) = (self.d_t.as_mut_slice(), self.sigma_t.as_mut_slice());
        let columns =
            d_t.chunks_exact_mut(n).zip(sigma_t.chunks_exact_mut(n)).zip(z_hat.iter().zip(z_rows.chunks_exact(2 * n)));
        for ((d, sg), (&zh, z_row)) in columns {
            let (plus, minus) = z_row.split_at(n);
            for (((d, sg), &zp), &zm) in d.iter_mut().zip(sg.iter_mut()).zip(plus).zip(minus) {
                *d = (zp - zm) * c;
                *sg = ((zp - zh) + (zm - zh)) * c;
            }
        }
        let (d_t, sigma_t) = (self.d_t.as_slice(), self.sigma_t.as_slice());

        // M = Tria([Σ̃, S_R,used]), then S_zz = Tria([D̃, M]): S_zz·S_zzᵀ = D̃·D̃ᵀ + Σ̃·Σ̃ᵀ + R = P_zz.
        let s_r_t = self.core.noise.r_sqrt_transposed().as_slice();
        for (a, &row) in rows.iter().enumerate() {
            let col = self.m_compound.column_mut(a);
            col[..n].copy_from_slice(&sigma_t[a * n..(a + 1) * n]);
            col[n..].copy_from_slice(&s_r_t[row * m..(row + 1) * m]);
        }
        self.m_compound.factor(mv, self.m_root.as_mut_slice(), m);
        let m_root = self.m_root.as_slice();
        for a in 0..mv {
            let col = self.zz_compound.column_mut(a);
            col[..n].copy_from_slice(&d_t[a * n..(a + 1) * n]);
            for (k, v) in col[n..].iter_mut().enumerate() {
                *v = if k < mv { m_root[k * m + a] } else { 0.0 };
            }
        }
        self.zz_compound.factor(mv, self.s_zz.as_mut_slice(), m);

        // P_xz = χ·γᵀ = S·D̃ᵀ (the points are x̂⁻ ± √n·S·eⱼ): column a is the
        // combination of S's columns with row a of D̃. Then W = P_xz·S_zz⁻ᵀ·S_zz⁻¹
        // by two triangular solves from the right.
        let s = self.s.as_slice();
        let gain = self.gain.as_mut_slice();
        for (p_a, d) in gain.chunks_exact_mut(n).zip(d_t.chunks_exact(n)).take(mv) {
            p_a.fill(0.0);
            lanes.combine(p_a, d, s, n);
        }
        let s_zz = self.s_zz.as_slice();
        let scratch = self.coefficients.as_mut_slice();
        let solved = solve_right_lower_transposed(lanes, s_zz, m, mv, gain, n, n, scratch)
            && solve_right_lower(lanes, s_zz, m, mv, gain, n, n, scratch);
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
        lanes.combine(x_next, &self.nu.as_slice()[..mv], gain, n);

        // W·M (M lower triangular): column k combines W's columns k.. with M's column k.
        let w_m = self.w_m.as_mut_slice();
        for (k, out) in w_m.chunks_exact_mut(n).enumerate().take(mv) {
            out.fill(0.0);
            lanes.combine(out, &m_root[k * m + k..k * m + mv], &gain[k * n..], n);
        }
        let w_m = self.w_m.as_slice();

        // S = Tria([S − W·D̃, W·M]). The SRCKF's compound [χ − W·γ, W·S_R] with
        // each pair of columns (j, n + j) rotated by 45°, which leaves A·Aᵀ
        // unchanged: the differences give S − W·D̃, the sums −W·Σ̃, and
        // [−W·Σ̃, W·S_R] has the same Gram matrix as W·M. 2n + m columns become n + m.
        // Column q of the transposed compound is row q of both blocks. Both
        // go in by transposes (Sᵀ on top, (W·M)ᵀ below); then row q of −W
        // (column q of −Wᵀ) combines D̃'s rows into the top of column q.
        // Sᵀ's columns are at hand in `s_t`, but a copy per column (a `memcpy`
        // call each) took more instructions than one transpose of S.
        let (compound, ld) = self.update_compound.columns_mut();
        lanes.transpose(self.s.as_slice(), n, n, n, compound, ld);
        lanes.transpose(w_m, n, n, mv, &mut compound[n..], ld);
        if mv < m {
            for col in compound.chunks_mut(ld).take(n) {
                col[n + mv..n + m].fill(0.0);
            }
        }
        let w_t = self.w_t.as_mut_slice();
        lanes.transpose(gain, n, n, mv, w_t, m);
        for c in w_t.iter_mut() {
            *c = -*c;
        }
        for (q, c) in w_t.chunks_exact(m).enumerate() {
            lanes.combine(&mut self.update_compound.column_mut(q)[..n], &c[..mv], d_t, n);
        }
        self.update_compound.factor_by_rows(n, self.s_t_next.as_mut_slice(), n);
        ensure_finite(self.core.x_next.as_slice(), Stage::Update, "updated state")?;
        ensure_finite(self.s_t_next.as_slice(), Stage::Update, "updated square-root covariance S")?;

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
        self.commit_factor(lanes);
        std::mem::swap(&mut self.core.x, &mut self.core.x_next);
        Ok(())
    }

    /// Makes the new factor (by rows, in `s_t_next`) the filter's `S`.
    #[inline(always)]
    /// `S ← Tria` of the predict compound as filled (by `add_process_noise`
    /// or `mix_with`, between steps), once it is finite; on error `S` is as it was.
    fn take_compound_root(&mut self, stage: Stage, what: &'static str) -> Result<(), FilterError> {
        let n = self.core.n();
        self.predict_compound.factor_by_rows(n, self.s_t_next.as_mut_slice(), n);
        ensure_finite(self.s_t_next.as_slice(), stage, what)?;
        std::mem::swap(&mut self.s_t, &mut self.s_t_next);
        self.s_t.transpose_to(&mut self.s);
        Ok(())
    }

    fn commit_factor<L: Lanes>(&mut self, lanes: L) {
        let n = self.core.n();
        std::mem::swap(&mut self.s_t, &mut self.s_t_next);
        lanes.transpose(self.s_t.as_slice(), n, n, n, self.s.as_mut_slice(), n);
    }
}

impl<M: Model> StateEstimator for SquareRootCubature<M> {
    core_accessors!();

    fn kind(&self) -> FilterKind {
        FilterKind::SrCkf
    }

    steps_with_avx2!(<M: Model> SquareRootCubature<M>);

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

    fn snapshot_into(&self, out: &mut crate::filter::Snapshot) {
        self.core.snapshot_into(FilterKind::SrCkf, &self.s, out)
    }

    fn restore(&mut self, snapshot: &crate::filter::Snapshot) -> Result<(), FilterError> {
        let covariance = self.core.restore(FilterKind::SrCkf, snapshot)?;
        self.s.copy_from_slice(covariance);
        self.s.transpose_to(&mut self.s_t);
        Ok(())
    }

    fn scale_covariance(&mut self, factor: f64) -> Result<(), FilterError> {
        check_scale(factor)?;
        // S·Sᵀ = P, so √factor·S is the root of factor·P.
        let root = factor.sqrt();
        self.s.scale_mut(root);
        self.s_t.scale_mut(root);
        Ok(())
    }

    fn mix_with(&mut self, other: &crate::filter::Snapshot, weight: f64) -> Result<(), FilterError> {
        // S̄ = Tria([√w·S, √(1 − w)·S_o, √(w(1 − w))·d]): the predict compound,
        // its top block √w·Sᵀ (upper triangular, as the layout wants).
        let other_s = self.core.mix_difference(FilterKind::SrCkf, other, weight)?;
        let n = self.core.n();
        let (a, b, c) = (weight.sqrt(), (1.0 - weight).sqrt(), (weight * (1.0 - weight)).sqrt());
        for r in 0..n {
            let d_r = self.core.x_next[r];
            let column = self.predict_compound.column_mut(r);
            for k in 0..n {
                column[k] = a * self.s[(r, k)];
                column[n + k] = b * other_s[k * n + r];
            }
            column[2 * n..].fill(0.0);
            column[2 * n] = c * d_r;
        }
        self.take_compound_root(Stage::Update, "square-root covariance S of the mixture")?;
        self.core.mix_mean(other, weight);
        Ok(())
    }

    fn add_process_noise(&mut self, factor: f64, states: &[bool]) -> Result<(), FilterError> {
        let n = self.core.n();
        check_process_noise_factor(factor, states, n)?;
        // S' = Tria([√factor·D·S_Q, S]) (D·S_Q·(D·S_Q)ᵀ = D·Q·D): the predict
        // compound, its top block √factor·(D·S_Q)ᵀ (upper triangular, as the
        // layout wants), then Sᵀ, then zeros.
        let q_sqrt = self.core.noise.q_sqrt();
        for r in 0..n {
            let root = if selected(states, r) { factor.sqrt() } else { 0.0 };
            let column = self.predict_compound.column_mut(r);
            for k in 0..n {
                column[k] = root * q_sqrt[(r, k)];
                column[n + k] = self.s[(r, k)];
            }
            column[2 * n..].fill(0.0);
        }
        self.take_compound_root(Stage::Predict, "square-root covariance S with the added process noise")
    }

    fn reset(&mut self, t0: f64, prior: &Gaussian) -> Result<(), FilterError> {
        self.core.reset(t0, prior)?;
        self.set_sqrt_from(&prior.covariance)
    }
}
