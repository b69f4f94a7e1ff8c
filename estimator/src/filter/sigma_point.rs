//! The covariance-form sigma-point Kalman filter, generic in its point set
//! (cubature or scaled unscented, a [`PointRule`] type) and in how it takes
//! the square root of `P` (Cholesky or SVD, a [`CovarianceRoot`] type). CKF,
//! SVD-CKF and UKF are instances of it, each a type of its own.
//!
//! Each cycle follows Arasaratnam & Haykin (2009), Algorithm 1:
//!
//! ```text
//! predict:  A·Aᵀ = P,  Xᵢ = x̂ ± c·A·eⱼ (and x̂),  Yᵢ = φ(Xᵢ)
//!           x̂⁻ = Σ wᵢ·Yᵢ,   P⁻ = Σ wᶜᵢ·(Yᵢ − x̂⁻)(Yᵢ − x̂⁻)ᵀ + Q
//! update:   A·Aᵀ = P⁻, Xᵢ = x̂⁻ ± c·A·eⱼ,  Zᵢ = h(Xᵢ)
//!           ẑ = Σ wᵢ·Zᵢ,   S = Σ wᶜᵢ·(Zᵢ − ẑ)(Zᵢ − ẑ)ᵀ + R,   C = Σ wᶜᵢ·(Xᵢ − x̂⁻)(Zᵢ − ẑ)ᵀ
//!           then the Kalman correction (see `correction.rs`).
//! ```

use std::marker::PhantomData;

use nalgebra::DMatrix;

use crate::error::{FilterError, Stage};
use crate::filter::core::{core_accessors, ensure_finite, steps_with_avx2, Core};
use crate::filter::correction::Correction;
use crate::filter::covariance_root::CovarianceRoot;
use crate::filter::point_blocks::PointBlocks;
use crate::filter::point_rule::PointRule;
use crate::filter::{check_scale, FilterKind, StateEstimator};
use crate::gaussian::Gaussian;
use crate::linalg::{axpy, symmetrize, Lanes, Portable};
use crate::model::Model;
use crate::noise::Noise;
use crate::points::SigmaPoints;

/// A sigma-point Kalman filter with a full covariance `P`, its square root
/// taken by `R` and its points spread by the rule `P`.
///
/// Use it through its named instances [`CubatureKalman`](crate::CubatureKalman),
/// [`SvdCubature`](crate::SvdCubature) and [`UnscentedKalman`](crate::UnscentedKalman).
#[derive(Debug, Clone)]
pub struct SigmaPointKalman<M, R, P> {
    kind: FilterKind,
    rule: PhantomData<P>,
    core: Core<M>,
    points: SigmaPoints,
    root: R,
    p: DMatrix<f64>,
    p_next: DMatrix<f64>,
    /// The square root of `P` used to spread the points.
    a: DMatrix<f64>,
    /// Points (`n × N`), then their deviations from the mean.
    xs: DMatrix<f64>,
    /// Propagated points (`n × N`), then their deviations.
    ys: DMatrix<f64>,
    /// Measurement points on the used rows (`m × N`, leading dimension `m`).
    zs: DMatrix<f64>,
    /// The points in blocks, as the model is called on them (see `model.rs`).
    x_blocks: PointBlocks,
    /// The propagated points in blocks.
    y_blocks: PointBlocks,
    /// The measurement points in blocks.
    z_blocks: PointBlocks,
    /// For the models' point-by-point defaults on blocks (`2n + m`).
    model_scratch: Vec<f64>,
    /// One coefficient per point: a weighted outer product's column, `wᶜᵢ·bᵢ[c]`.
    coefficients: Vec<f64>,
    correction: Correction,
}

impl<M: Model, R: CovarianceRoot, P: PointRule> SigmaPointKalman<M, R, P> {
    pub(crate) fn with_points(
        kind: FilterKind,
        model: M,
        noise: Noise,
        prior: &Gaussian,
        points: SigmaPoints,
    ) -> Result<Self, FilterError> {
        let core = Core::new(model, noise, 0.0, prior)?;
        let (n, m, count) = (core.n(), core.m(), points.len());
        Ok(Self {
            kind,
            rule: PhantomData,
            points,
            root: R::new(n),
            p: prior.covariance.clone(),
            p_next: DMatrix::zeros(n, n),
            a: DMatrix::zeros(n, n),
            xs: DMatrix::zeros(n, count),
            ys: DMatrix::zeros(n, count),
            zs: DMatrix::zeros(m, count),
            x_blocks: PointBlocks::new(n, count),
            y_blocks: PointBlocks::new(n, count),
            z_blocks: PointBlocks::new(m, count),
            model_scratch: vec![0.0; 2 * n + m],
            coefficients: vec![0.0; count],
            correction: Correction::new(n, m),
            core,
        })
    }

    /// The model.
    pub fn model(&self) -> &M {
        &self.core.model
    }

    /// The model, to change its parameters between steps.
    pub fn model_mut(&mut self) -> &mut M {
        &mut self.core.model
    }

    /// The point set in use.
    pub fn points(&self) -> &SigmaPoints {
        &self.points
    }

    /// The time update (compiled once for the baseline CPU and once with AVX2 and FMA, see `steps_with_avx2!`).
    #[inline(always)]
    fn predict_body<L: Lanes>(&mut self, lanes: L, u: &[f64], dt: f64) -> Result<(), FilterError> {
        self.core.begin_predict(u, dt)?;
        self.spread(Stage::Predict)?;
        let n = self.core.n();
        let t = self.core.t;
        let u = self.core.u.as_slice();
        self.x_blocks.load_columns(self.xs.as_slice(), self.core.x.as_slice());
        for (x, y) in self.x_blocks.blocks().zip(self.y_blocks.blocks_mut()) {
            self.core.model.transition_block(t, dt, x, u, y, &mut self.model_scratch);
        }
        self.y_blocks.store_columns(self.ys.as_mut_slice());
        ensure_finite(self.ys.as_slice(), Stage::Predict, "propagated sigma points")?;
        weighted_mean(&self.ys, &self.points, self.core.x_next.as_mut_slice());
        subtract_mean(&mut self.ys, self.core.x_next.as_slice());
        self.p_next.copy_from(self.core.noise.q());
        let products = (&self.points, self.coefficients.as_mut_slice());
        add_weighted_outer_products(lanes, self.p_next.as_mut_slice(), n, (&self.ys, n), (&self.ys, n), products);
        symmetrize(&mut self.p_next);
        ensure_finite(self.p_next.as_slice(), Stage::Predict, "predicted covariance P")?;
        if let Some(cross) = &mut self.core.cross {
            // Σ wᶜᵢ·(Xᵢ − x̂)(Yᵢ − x̂⁻)ᵀ; the points are spread again at the update.
            subtract_mean(&mut self.xs, self.core.x.as_slice());
            cross.fill(0.0);
            let products = (&self.points, self.coefficients.as_mut_slice());
            add_weighted_outer_products(lanes, cross.as_mut_slice(), n, (&self.xs, n), (&self.ys, n), products);
        }
        std::mem::swap(&mut self.core.x, &mut self.core.x_next);
        std::mem::swap(&mut self.p, &mut self.p_next);
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
        self.spread(Stage::Update)?;
        let (n, m, count) = (self.core.n(), self.core.m(), self.points.len());
        let (t, u) = (self.core.t, self.core.u.as_slice());
        self.x_blocks.load_columns(self.xs.as_slice(), self.core.x.as_slice());
        let zb = &mut self.z_blocks;
        for (x, z) in self.x_blocks.blocks().zip(zb.blocks_mut()) {
            self.core.model.observe_block(t, x, u, z, &mut self.model_scratch);
        }
        for (i, point) in self.zs.as_mut_slice().chunks_exact_mut(m).enumerate() {
            for (v, &row) in point.iter_mut().zip(self.core.innovation.rows()) {
                *v = zb.get(row, i);
            }
        }
        for point in self.zs.as_slice().chunks_exact(m) {
            ensure_finite(&point[..mv], Stage::Update, "measurement sigma points")?;
        }
        let cr = &mut self.correction;
        cr.z_hat.fill(0.0);
        for i in 0..count {
            axpy(
                self.points.mean_weight(i),
                &self.zs.as_slice()[i * m..i * m + mv],
                &mut cr.z_hat.as_mut_slice()[..mv],
            );
        }
        for i in 0..count {
            let col = &mut self.zs.as_mut_slice()[i * m..i * m + mv];
            for (v, zh) in col.iter_mut().zip(cr.z_hat.iter()) {
                *v -= zh;
            }
        }
        subtract_mean(&mut self.xs, self.core.x.as_slice());
        cr.set_noise_part(self.core.noise.r(), self.core.innovation.rows());
        let products = (&self.points, self.coefficients.as_mut_slice());
        add_weighted_outer_products(lanes, cr.s.as_mut_slice(), m, (&self.zs, mv), (&self.zs, mv), products);
        cr.c.fill(0.0);
        let products = (&self.points, self.coefficients.as_mut_slice());
        add_weighted_outer_products(lanes, cr.c.as_mut_slice(), n, (&self.xs, n), (&self.zs, mv), products);
        cr.apply(
            &self.core.z,
            (&mut self.core.x, &mut self.core.x_next),
            (&mut self.p, &mut self.p_next),
            &mut self.core.innovation,
        )
    }

    /// Spreads the points around `x` with the square root of `p`.
    #[inline(always)]
    fn spread(&mut self, stage: Stage) -> Result<(), FilterError> {
        let x = &self.core.x;
        self.root
            .factor(&self.p, &mut self.a)
            .map_err(|_| FilterError::NotPositiveDefinite { stage, matrix: "state covariance P" })?;
        let n = x.len();
        let c = self.points.spread();
        let xs = self.xs.as_mut_slice();
        let a = self.a.as_slice();
        for j in 0..n {
            let col = &a[j * n..(j + 1) * n];
            for i in 0..n {
                xs[j * n + i] = x[i] + c * col[i];
                xs[(n + j) * n + i] = x[i] - c * col[i];
            }
        }
        if self.points.center().is_some() {
            xs[2 * n * n..(2 * n + 1) * n].copy_from_slice(x.as_slice());
        }
        Ok(())
    }
}

impl<M: Model, R: CovarianceRoot, P: PointRule> StateEstimator for SigmaPointKalman<M, R, P> {
    core_accessors!();

    fn kind(&self) -> FilterKind {
        self.kind
    }

    steps_with_avx2!(<M: Model, R: CovarianceRoot, P: PointRule> SigmaPointKalman<M, R, P>);

    fn write_covariance(&self, out: &mut DMatrix<f64>) {
        out.copy_from(&self.p);
    }

    fn variance(&self, i: usize) -> f64 {
        self.p[(i, i)]
    }

    fn snapshot_into(&self, out: &mut crate::filter::Snapshot) {
        self.core.snapshot_into(self.kind, &self.p, out)
    }

    fn restore(&mut self, snapshot: &crate::filter::Snapshot) -> Result<(), FilterError> {
        let covariance = self.core.restore(self.kind, snapshot)?;
        self.p.copy_from_slice(covariance);
        Ok(())
    }

    fn scale_covariance(&mut self, factor: f64) -> Result<(), FilterError> {
        check_scale(factor)?;
        self.p.scale_mut(factor);
        Ok(())
    }

    fn mix_with(&mut self, other: &crate::filter::Snapshot, weight: f64) -> Result<(), FilterError> {
        self.core.mix_covariance(self.kind, &mut self.p, &mut self.p_next, other, weight)
    }

    fn add_process_noise(&mut self, factor: f64, states: &[bool]) -> Result<(), FilterError> {
        self.core.add_process_noise_to(&mut self.p, &mut self.p_next, factor, states)
    }

    fn reset(&mut self, t0: f64, prior: &Gaussian) -> Result<(), FilterError> {
        self.core.reset(t0, prior)?;
        self.p.copy_from(&prior.covariance);
        Ok(())
    }
}

/// `out = Σ wᵢ·colᵢ` with the points' mean weights.
#[inline(always)]
fn weighted_mean(points: &DMatrix<f64>, set: &SigmaPoints, out: &mut [f64]) {
    let n = out.len();
    out.fill(0.0);
    for i in 0..set.len() {
        axpy(set.mean_weight(i), &points.as_slice()[i * n..(i + 1) * n], out);
    }
}

/// Subtracts `mean` from every column.
#[inline(always)]
fn subtract_mean(points: &mut DMatrix<f64>, mean: &[f64]) {
    let n = mean.len();
    for col in points.as_mut_slice().chunks_exact_mut(n) {
        for (v, m) in col.iter_mut().zip(mean) {
            *v -= m;
        }
    }
}

/// `out += Σ wᶜᵢ·aᵢ·bᵢᵀ` over the columns of `a` (first `rows_a` rows) and `b` (first
/// `rows_b` rows); `out` has leading dimension `ld_out`. Column `c` of the sum is a linear
/// combination of the columns of `a` with the coefficients `wᶜᵢ·bᵢ[c]` (written to
/// `coefficients`, one per point), which [`Lanes::combine`] forms in registers, the terms
/// added point by point as a plain loop over the points would.
#[inline(always)]
fn add_weighted_outer_products<L: Lanes>(
    lanes: L,
    out: &mut [f64],
    ld_out: usize,
    (a, rows_a): (&DMatrix<f64>, usize),
    (b, rows_b): (&DMatrix<f64>, usize),
    (set, coefficients): (&SigmaPoints, &mut [f64]),
) {
    let (lda, ldb, count) = (a.nrows(), b.nrows(), set.len());
    let coefficients = &mut coefficients[..count];
    // A set with a negative weight (the UKF's centre, for a small α) sums terms that
    // cancel: fusing their roundings moves the filter's run far more than rounding (on
    // S2's model by 2e-2 over 1000 steps, `tests/portable.rs`), so it keeps the unfused loop.
    let fused = set.covariance_weights_nonnegative();
    for c in 0..rows_b {
        for (i, w) in coefficients.iter_mut().enumerate() {
            *w = set.covariance_weight(i) * b.as_slice()[i * ldb + c];
        }
        let column = &mut out[c * ld_out..c * ld_out + rows_a];
        if fused {
            lanes.combine(column, coefficients, a.as_slice(), lda);
        } else {
            Portable.combine(column, coefficients, a.as_slice(), lda);
        }
    }
}
