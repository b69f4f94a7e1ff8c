//! `Tria`: the triangularisation at the heart of square-root filters.
//!
//! Given a compound matrix `A` (`n × r`, any `r`), `Tria(A)` is a lower-triangular
//! `S` with `S·Sᵀ = A·Aᵀ`. It is computed as `Rᵀ` from a Householder QR of `Aᵀ`
//! (Arasaratnam & Haykin 2009, eq. (41)); `Q` is never formed.
//!
//! [`Tria`] owns `Aᵀ` (column-major, one column per row of `A`) and its scratch,
//! so a filter builds it once and refills it every step. Two layouts:
//!
//! * [`Tria::dense`]: `Aᵀ` has no structure;
//! * [`Tria::upper_on_top`]: the first `cols` rows of `Aᵀ` are upper triangular,
//!   as `S_Qᵀ` is in the predict compound `[S_Q, Y*]ᵀ` once `S_Q` is lower
//!   triangular. Reflection `k` then touches only row `k` of that block and the
//!   dense rows below it, which saves a quarter of the work for `3n × n`; the
//!   dense part of each reflector is its column as it stands, used in place.
//!
//! The rows of each column are padded with zeros to a multiple of [`LANES`], so
//! the inner loops run over whole chunks (see `lanes.rs`: portable, or AVX2
//! with FMA chosen at run time, equal to rounding).

#[cfg(target_arch = "x86_64")]
use super::lanes::Avx2;
use super::lanes::{Lanes, Portable, COLUMN_BLOCK, LANES};

/// A compound matrix `Aᵀ` and the workspace to triangularise it.
#[derive(Debug, Clone)]
pub(crate) struct Tria {
    rows: usize,
    cols: usize,
    /// Rows at the top that are upper triangular (0 or `cols`).
    top: usize,
    /// Leading dimension: `top` plus the dense rows rounded up to [`LANES`].
    ld: usize,
    at: Vec<f64>,
    /// The dense parts of a pair of reflectors, zero outside the rows they
    /// act on (without structure; with an upper-triangular top they are the
    /// columns themselves, and these stay empty).
    v: Vec<f64>,
    v2: Vec<f64>,
    /// `vᵀ·aⱼ` for the trailing columns; after the QR, the signs that make
    /// the diagonal of `S` non-negative.
    w: Vec<f64>,
    /// The signs as a sign bit, and the mask of the columns a row of `S`
    /// keeps (`factor_by_rows`).
    flip: Vec<u64>,
    keep: Vec<u64>,
}

impl Tria {
    /// `Aᵀ` of `rows × cols` without structure.
    pub(crate) fn dense(rows: usize, cols: usize) -> Self {
        Self::with_top(0, rows, cols)
    }

    /// `Aᵀ` of `rows × cols` (`rows ≥ cols`) whose first `cols` rows are upper
    /// triangular. Entries below the diagonal of that block are never read.
    pub(crate) fn upper_on_top(rows: usize, cols: usize) -> Self {
        assert!(rows >= cols, "Tria::upper_on_top: {rows} rows for {cols} columns");
        Self::with_top(cols, rows, cols)
    }

    fn with_top(top: usize, rows: usize, cols: usize) -> Self {
        let ld = top + (rows - top).div_ceil(LANES) * LANES;
        let v_len = if top == 0 { ld } else { 0 };
        Self {
            rows,
            cols,
            top,
            ld,
            at: vec![0.0; ld * cols],
            v: vec![0.0; v_len],
            v2: vec![0.0; v_len],
            w: vec![0.0; cols],
            flip: vec![0; cols],
            keep: vec![0; cols],
        }
    }

    /// Column `j` of `Aᵀ` (row `j` of `A`), `rows` entries, to be filled.
    pub(crate) fn column_mut(&mut self, j: usize) -> &mut [f64] {
        &mut self.at[j * self.ld..j * self.ld + self.rows]
    }

    /// Every column of `Aᵀ`, column-major, and its leading dimension, to fill
    /// a block of rows of all the columns at once (with `Lanes::transpose`).
    /// The rows past `rows` in each column are padding: what is written there is cleared.
    pub(crate) fn columns_mut(&mut self) -> (&mut [f64], usize) {
        (&mut self.at, self.ld)
    }

    /// Triangularises the first `cols` columns of `Aᵀ` (at most the `cols` it
    /// was built for) and writes the lower-triangular `cols × cols` result to
    /// `s` (leading dimension `lds`), its strict upper triangle zeroed and its
    /// diagonal made non-negative (column signs of a square root are free;
    /// fixing them makes the factor unique, equal to the Cholesky factor of
    /// `A·Aᵀ` when that exists). `Aᵀ` is destroyed.
    pub(crate) fn factor(&mut self, cols: usize, s: &mut [f64], lds: usize) {
        self.triangularize(cols);
        self.write_factor(cols, s, lds);
    }

    /// [`Tria::factor`], with `S` written by rows: `out[i·ldo + k] = S[i, k]`
    /// (zeros right of the diagonal). Row `i` of `S` is column `i` of `R`,
    /// which lies in column `i` of `Aᵀ`: a contiguous copy, unlike `S` by columns.
    #[inline(always)]
    pub(crate) fn factor_by_rows(&mut self, cols: usize, out: &mut [f64], ldo: usize) {
        self.triangularize(cols);
        let (ld, steps) = (self.ld, self.rows.min(cols));
        // Never past the column of Aᵀ (fewer rows than columns).
        let width = cols.min(ld);
        // Each entry of the row as bits: its sign flipped by the column's sign
        // (`flip`), then kept or cleared to +0 (`keep`). Going from the last
        // row up, `keep` loses one column per row, so every row is one pass of
        // equal lengths with no branch, which the caller's vector code takes whole.
        const SIGN: u64 = 1 << 63;
        for (k, (flip, keep)) in self.flip[..width].iter_mut().zip(&mut self.keep[..width]).enumerate() {
            *flip = self.w[k].to_bits() & SIGN;
            *keep = if k < steps { u64::MAX } else { 0 };
        }
        for i in (0..cols).rev() {
            let row = &mut out[i * ldo..i * ldo + cols];
            let (head, rest) = row.split_at_mut(width);
            let column = &self.at[i * ld..i * ld + width];
            for (o, ((&r, &flip), &keep)) in
                head.iter_mut().zip(column.iter().zip(&self.flip[..width]).zip(&self.keep[..width]))
            {
                *o = f64::from_bits((r.to_bits() ^ flip) & keep);
            }
            rest.fill(0.0);
            if i < width {
                self.keep[i] = 0;
            }
        }
    }

    /// The Householder QR, then the signs that make the diagonal of `S`
    /// non-negative (in `w`).
    fn triangularize(&mut self, cols: usize) {
        assert!(cols <= self.cols, "Tria::factor: {cols} columns for a workspace of {}", self.cols);
        #[cfg(target_arch = "x86_64")]
        if let Some(avx2) = Avx2::selected() {
            self.householder_avx2(avx2, cols);
        } else {
            self.householder(Portable, cols);
        }
        #[cfg(not(target_arch = "x86_64"))]
        self.householder(Portable, cols);
        let (ld, steps) = (self.ld, self.rows.min(cols));
        for (k, sign) in self.w[..cols].iter_mut().enumerate() {
            *sign = if k < steps && self.at[k * ld + k] < 0.0 { -1.0 } else { 1.0 };
        }
    }

    /// The Householder QR compiled with AVX2 and FMA enabled throughout.
    #[cfg(target_arch = "x86_64")]
    fn householder_avx2(&mut self, avx2: Avx2, cols: usize) {
        #[target_feature(enable = "avx2,fma")]
        fn run(tria: &mut Tria, avx2: Avx2, cols: usize) {
            tria.householder(avx2, cols);
        }
        #[allow(unsafe_code)]
        // SAFETY: `avx2` exists, so the CPU has AVX2 and FMA.
        unsafe {
            run(self, avx2, cols)
        }
    }

    /// Householder QR of `Aᵀ` in place: `R` ends up in the head rows.
    ///
    /// The reflectors go in pairs: reflector `k` is formed and applied to
    /// column `k + 1`, reflector `k + 1` is formed from it, and the two are
    /// applied together to the columns after (`apply_pair`), so each of those
    /// is read and written once per pair instead of once per reflector.
    #[inline(always)]
    fn householder<L: Lanes>(&mut self, lanes: L, cols: usize) {
        if self.top > 0 {
            self.householder_with::<L, true>(lanes, cols)
        } else {
            self.householder_with::<L, false>(lanes, cols)
        }
    }

    /// [`Tria::householder`], compiled apart for the two layouts (a run-time
    /// flag in the loop cost more than the copies it saves).
    #[inline(always)]
    fn householder_with<L: Lanes, const IN_PLACE: bool>(&mut self, lanes: L, cols: usize) {
        let (rows, top, ld) = (self.rows, self.top, self.ld);
        // The padding rows stay zero through every reflection, unless an earlier
        // call met a non-finite input: clear them so one bad step cannot poison the next.
        for col in self.at.chunks_exact_mut(ld).take(cols) {
            col[rows..].fill(0.0);
        }
        let steps = rows.min(cols);
        // With an upper-triangular top (`IN_PLACE`), every reflector acts on
        // its head row and on all the dense rows, which lie below the head
        // rows from `top` on: its dense part is the column itself, used in place.
        let mut k = 0;
        while k < steps {
            // The reflectors act on their head row and on the dense rows
            // below it, run over from the chunk boundary `start`.
            let start = if IN_PLACE { top } else { k - k % LANES };
            let (head, tail) = self.at.split_at_mut((k + 1) * ld);
            let col = &mut head[k * ld..];
            let first = if IN_PLACE {
                reflector_in_place(lanes, col, k, start)
            } else {
                reflector(lanes, col, &mut self.v[start..], k, start, rows)
            };
            let v1: &[f64] = if IN_PLACE { &col[start..] } else { &self.v[start..] };
            if k + 1 == steps {
                apply(lanes, &first, v1, start, ld, &mut tail[..(cols - k - 1) * ld], &mut self.w);
                break;
            }
            let (next, rest) = tail.split_at_mut(ld);
            apply(lanes, &first, v1, start, ld, next, &mut self.w);
            let second = if IN_PLACE {
                reflector_in_place(lanes, next, k + 1, start)
            } else {
                reflector(lanes, next, &mut self.v2[start..], k + 1, start, rows)
            };
            let v2: &[f64] = if IN_PLACE { &next[start..] } else { &self.v2[start..] };
            apply_pair(lanes, [&first, &second], [v1, v2], start, ld, &mut rest[..(cols - k - 2) * ld]);
            k += 2;
        }
    }

    /// `S = Rᵀ`, rows of `R` (columns of `S`) flipped by the signs in `w`.
    fn write_factor(&self, cols: usize, s: &mut [f64], lds: usize) {
        let (ld, steps) = (self.ld, self.rows.min(cols));
        for k in 0..cols {
            s[k * lds..k * lds + cols].fill(0.0);
        }
        // Column i of Aᵀ holds row i of S (its first min(i + 1, steps) entries).
        for i in 0..cols {
            let known = (i + 1).min(steps);
            for (k, (&r, &sign)) in self.at[i * ld..i * ld + known].iter().zip(&self.w).enumerate() {
                s[k * lds + i] = sign * r;
            }
        }
    }
}

/// `H = I − τ·u·uᵀ`, with `u = v₀·e_k + v`: a head entry in row `k` and a
/// dense part `v` (kept by the caller from row `start`, zero outside the rows
/// it acts on). `τ = 0` is the identity.
struct Reflector {
    k: usize,
    v0: f64,
    tau: f64,
}

/// Forms the reflector that zeroes `col` (a column of `Aᵀ`) in rows `k + 1..rows`
/// and writes `α = ∓‖x‖` to its row `k`; `v` (from row `start`) receives the dense part.
#[inline(always)]
fn reflector<L: Lanes>(lanes: L, col: &mut [f64], v: &mut [f64], k: usize, start: usize, rows: usize) -> Reflector {
    let first = k + 1;
    let (zeros, rest) = v.split_at_mut(first - start);
    let (part, padding) = rest.split_at_mut(rows - first);
    zeros.fill(0.0);
    part.copy_from_slice(&col[first..rows]);
    padding.fill(0.0);
    let norm2 = col[k] * col[k] + lanes.dot(v, v);
    head_of(col, k, norm2)
}

/// [`reflector`] for a column whose rows from `first` on (whole chunks, the
/// padding zero) are the dense part as they stand: they are left in place.
#[inline(always)]
fn reflector_in_place<L: Lanes>(lanes: L, col: &mut [f64], k: usize, first: usize) -> Reflector {
    let norm2 = col[k] * col[k] + lanes.dot(&col[first..], &col[first..]);
    head_of(col, k, norm2)
}

/// The reflector with head row `k` of `col`, given `‖x‖²`; writes `α` to row `k`.
#[inline(always)]
fn head_of(col: &mut [f64], k: usize, norm2: f64) -> Reflector {
    let x0 = col[k];
    if norm2 == 0.0 {
        return Reflector { k, v0: 0.0, tau: 0.0 };
    }
    let norm = norm2.sqrt();
    let alpha = if x0 >= 0.0 { -norm } else { norm };
    col[k] = alpha;
    // u = x − α·e_k, so uᵀu = 2‖x‖(‖x‖ + |x₀|): no cancellation.
    Reflector { k, v0: x0 - alpha, tau: 1.0 / (norm * (norm + x0.abs())) }
}

/// Applies `H` to every column of `columns` (leading dimension `ld`):
/// `aⱼ −= τ·(uᵀaⱼ)·u`, with the products formed [`COLUMN_BLOCK`] columns per pass over `v`.
#[inline(always)]
fn apply<L: Lanes>(lanes: L, h: &Reflector, v: &[f64], start: usize, ld: usize, columns: &mut [f64], w: &mut [f64]) {
    if h.tau == 0.0 {
        return;
    }
    let w = &mut w[..columns.len() / ld];
    let mut blocks = columns.chunks_exact(COLUMN_BLOCK * ld);
    let mut out = w.chunks_exact_mut(COLUMN_BLOCK);
    for (block, wb) in (&mut blocks).zip(&mut out) {
        let c: [&[f64]; COLUMN_BLOCK] = std::array::from_fn(|b| &block[b * ld + start..(b + 1) * ld]);
        let dots = lanes.dots(v, c);
        for (b, wj) in wb.iter_mut().enumerate() {
            *wj = h.v0 * block[b * ld + h.k] + dots[b];
        }
    }
    for (col, wj) in blocks.remainder().chunks_exact(ld).zip(out.into_remainder()) {
        *wj = h.v0 * col[h.k] + lanes.dot(v, &col[start..]);
    }
    for (col, &wj) in columns.chunks_exact_mut(ld).zip(w.iter()) {
        if wj != 0.0 {
            let c = h.tau * wj;
            col[h.k] -= c * h.v0;
            lanes.sub_scaled(&mut col[start..], c, v);
        }
    }
}

/// Applies `H₂·H₁` to every column of `columns`, reading and writing each once:
///
/// ```text
/// c₁ = τ₁·u₁ᵀa,   c₂ = τ₂·(u₂ᵀa − c₁·u₂ᵀu₁),   a ← a − c₁·u₁ − c₂·u₂
/// ```
///
/// (`u₂ᵀ(a − c₁·u₁)` expanded). `u₂`'s head row is `k₁ + 1`, where `u₁` may
/// have a dense entry; `u₁`'s head row `k₁` is outside `u₂`.
#[inline(always)]
fn apply_pair<L: Lanes>(lanes: L, h: [&Reflector; 2], v: [&[f64]; 2], start: usize, ld: usize, columns: &mut [f64]) {
    if h[0].tau == 0.0 && h[1].tau == 0.0 {
        return;
    }
    let k2 = h[1].k;
    let v1_at_k2 = if k2 >= start { v[0][k2 - start] } else { 0.0 };
    let g = h[1].v0 * v1_at_k2 + lanes.dot(v[1], v[0]);
    // A function, not a closure: a closure is compiled apart, without the caller's AVX2.
    #[inline(always)]
    fn update<L: Lanes>(
        lanes: L,
        h: [&Reflector; 2],
        v: [&[f64]; 2],
        start: usize,
        g: f64,
        col: &mut [f64],
        w: [f64; 2],
    ) {
        let c1 = h[0].tau * w[0];
        let c2 = h[1].tau * (w[1] - c1 * g);
        if c1 != 0.0 || c2 != 0.0 {
            lanes.sub_scaled_2(&mut col[start..], [c1, c2], v);
            col[h[0].k] -= c1 * h[0].v0;
            col[h[1].k] -= c2 * h[1].v0;
        }
    }
    let mut pairs = columns.chunks_exact_mut(2 * ld);
    for pair in &mut pairs {
        let (a0, a1) = pair.split_at_mut(ld);
        let dots = lanes.dots_2x2(v, [&a0[start..], &a1[start..]]);
        for (b, col) in [a0, a1].into_iter().enumerate() {
            let w1 = h[0].v0 * col[h[0].k] + dots[0][b];
            let w2 = h[1].v0 * col[k2] + dots[1][b];
            update(lanes, h, v, start, g, col, [w1, w2]);
        }
    }
    let last = pairs.into_remainder();
    if !last.is_empty() {
        let w1 = h[0].v0 * last[h[0].k] + lanes.dot(v[0], &last[start..]);
        let w2 = h[1].v0 * last[k2] + lanes.dot(v[1], &last[start..]);
        update(lanes, h, v, start, g, last, [w1, w2]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DMatrix;

    fn compound(n: usize, r: usize) -> DMatrix<f64> {
        DMatrix::from_fn(n, r, |i, j| (((i * 13 + j * 7) % 17) as f64 - 8.0) / 3.0)
    }

    fn fill(tria: &mut Tria, at: &DMatrix<f64>) {
        for j in 0..at.ncols() {
            tria.column_mut(j).copy_from_slice(at.column(j).as_slice());
        }
    }

    fn run(a: &DMatrix<f64>) -> DMatrix<f64> {
        let (n, r) = a.shape();
        let mut tria = Tria::dense(r, n);
        fill(&mut tria, &a.transpose());
        let mut s = DMatrix::from_element(n, n, f64::NAN);
        tria.factor(n, s.as_mut_slice(), n);
        s
    }

    fn assert_square_root(s: &DMatrix<f64>, a: &DMatrix<f64>, what: &str) {
        let aat = a * a.transpose();
        assert!((s * s.transpose() - &aat).norm() <= 1e-12 * aat.norm(), "{what}");
        for j in 0..s.ncols() {
            assert!(s[(j, j)] >= 0.0, "{what}: negative diagonal");
            for i in 0..j {
                assert_eq!(s[(i, j)], 0.0, "{what}: not lower triangular");
            }
        }
    }

    #[test]
    fn square_root_reproduces_a_a_transposed_and_is_lower_with_positive_diagonal() {
        for &(n, r) in &[(1, 1), (3, 9), (6, 18), (24, 72), (5, 5), (24, 55), (7, 55), (9, 17)] {
            let a = compound(n, r);
            assert_square_root(&run(&a), &a, &format!("n={n} r={r}"));
        }
    }

    #[test]
    fn equals_the_cholesky_factor_when_a_a_transposed_is_positive_definite() {
        let a = compound(6, 18);
        let aat = &a * a.transpose();
        let l = aat.clone().cholesky().unwrap().l();
        assert!((run(&a) - l).norm() < 1e-11 * aat.norm());
    }

    #[test]
    fn rows_are_the_rows_of_the_factor() {
        for &(n, r) in &[(24, 55), (5, 3), (7, 7), (12, 3)] {
            let a = compound(n, r);
            let mut tria = Tria::dense(r, n);
            fill(&mut tria, &a.transpose());
            let mut s = DMatrix::from_element(n, n, f64::NAN);
            tria.factor(n, s.as_mut_slice(), n);
            let mut rows = DMatrix::from_element(n + 2, n, f64::NAN);
            fill(&mut tria, &a.transpose());
            tria.factor_by_rows(n, rows.as_mut_slice(), n + 2);
            assert_eq!(rows.rows(0, n), s.transpose(), "n={n} r={r}");
            assert!(rows.rows(n, 2).iter().all(|v| v.is_nan()), "n={n} r={r}: wrote outside the rows");
        }
    }

    #[test]
    fn rank_deficient_input_gives_a_valid_factor() {
        // Fewer columns than rows, and a zero column: S·Sᵀ must still equal A·Aᵀ.
        let mut a = compound(5, 3);
        a.column_mut(1).fill(0.0);
        assert_square_root(&run(&a), &a, "rank deficient");
    }

    #[test]
    fn zero_rows_of_a_give_identity_reflectors_in_either_place_of_a_pair() {
        // A zero row of A is a zero column of Aᵀ: its reflector is the identity
        // (τ = 0), first or second of a pair, or both, or the odd last one.
        for zero_rows in [&[0][..], &[1], &[0, 1], &[2, 3, 6], &[6]] {
            let mut a = compound(7, 20);
            for &i in zero_rows {
                a.row_mut(i).fill(0.0);
            }
            assert_square_root(&run(&a), &a, &format!("zero rows {zero_rows:?}"));
        }
    }

    #[test]
    fn an_upper_triangular_top_block_gives_the_dense_result() {
        // A = [L, B] with L lower triangular: Aᵀ = [Lᵀ; Bᵀ] has an upper-triangular top.
        for &(n, extra) in &[(1, 2), (6, 12), (24, 48), (13, 5)] {
            let mut a = compound(n, n + extra);
            for j in 0..n {
                for i in 0..j {
                    a[(i, j)] = 0.0;
                }
            }
            let mut structured = Tria::upper_on_top(n + extra, n);
            let mut at = a.transpose();
            // What lies below the top block's diagonal is never read.
            for j in 0..n {
                for i in j + 1..n {
                    at[(i, j)] = f64::NAN;
                }
            }
            fill(&mut structured, &at);
            let mut s = DMatrix::from_element(n, n, f64::NAN);
            structured.factor(n, s.as_mut_slice(), n);
            assert_square_root(&s, &a, &format!("n={n} extra={extra}"));
            assert!((&s - run(&a)).norm() <= 1e-12 * s.norm(), "n={n}: differs from the dense factor");
        }
    }

    #[test]
    fn fewer_columns_than_built_for_use_the_leading_block() {
        let a = compound(7, 20);
        let mut tria = Tria::dense(20, 7);
        fill(&mut tria, &a.transpose());
        let mut s = DMatrix::from_element(4, 4, f64::NAN);
        tria.factor(4, s.as_mut_slice(), 4);
        assert_square_root(&s, &a.rows(0, 4).into_owned(), "leading 4 of 7");
    }

    #[test]
    fn a_non_finite_input_does_not_poison_the_next_factorisation() {
        let a = compound(6, 18);
        let mut tria = Tria::dense(18, 6);
        let mut bad = a.transpose();
        bad[(3, 2)] = f64::INFINITY;
        fill(&mut tria, &bad);
        let mut s = DMatrix::zeros(6, 6);
        tria.factor(6, s.as_mut_slice(), 6);
        fill(&mut tria, &a.transpose());
        tria.factor(6, s.as_mut_slice(), 6);
        assert_square_root(&s, &a, "after a non-finite input");
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn the_avx2_path_gives_the_portable_result_to_rounding() {
        let Some(avx2) = Avx2::detect() else {
            eprintln!("no AVX2 and FMA on this CPU: only the portable path runs here");
            return;
        };
        for &(rows, cols, upper) in &[(72, 24, true), (55, 24, false), (55, 7, false), (13, 5, false), (9, 9, true)] {
            let a = compound(cols, rows);
            let build = || {
                let mut t = if upper { Tria::upper_on_top(rows, cols) } else { Tria::dense(rows, cols) };
                fill(&mut t, &a.transpose());
                t
            };
            let (mut fast, mut portable) = (build(), build());
            fast.householder_avx2(avx2, cols);
            portable.householder(Portable, cols);
            let size = a.norm();
            let worst = fast.at.iter().zip(&portable.at).map(|(f, p)| (f - p).abs()).fold(0.0, f64::max);
            assert!(worst <= 1e-14 * size, "rows={rows} cols={cols} upper={upper}: {worst:e} apart, size {size:e}");
        }
    }
}
