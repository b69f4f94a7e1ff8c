//! The inner loops of the dense kernels, in two implementations: portable
//! Rust, and AVX2 with FMA intrinsics chosen at run time.
//!
//! The two agree to rounding, not bit for bit: the AVX2 path fuses each
//! multiply-add (one rounding instead of two) and sums its lanes in its own
//! order. Each path on its own is deterministic, so a filter gives the same
//! numbers run after run and on every CPU that takes the same path (every
//! x86-64 CPU since 2013 has AVX2 and FMA). The compiler's own vectoriser,
//! given the same loops under AVX2, packs across columns with shuffles: it
//! took 2.2× the instructions of these intrinsics for the Householder QR
//! (callgrind, `examples/step_loop.rs`).
//!
//! The AVX2 implementation is reached only through an [`Avx2`] token, which
//! exists only on a CPU that has AVX2 and FMA; that is what makes its calls sound.

/// `f64` per chunk: two AVX2 registers.
pub(crate) const LANES: usize = 8;

/// Columns whose products with one vector are formed in one pass over it.
pub(crate) const COLUMN_BLOCK: usize = 4;

/// One chunk of lanes.
pub(crate) type Chunk = [f64; LANES];

/// The inner loops. Except for [`Lanes::combine`], slices are whole numbers
/// of chunks (their length a multiple of [`LANES`]) and paired slices have
/// equal lengths.
pub(crate) trait Lanes: Copy {
    /// `vᵀ·cᵦ` for [`COLUMN_BLOCK`] columns.
    fn dots(self, v: &[f64], c: [&[f64]; COLUMN_BLOCK]) -> [f64; COLUMN_BLOCK];
    /// `aᵀ·b`.
    fn dot(self, a: &[f64], b: &[f64]) -> f64;
    /// `x[i] −= c·v[i]`.
    fn sub_scaled(self, x: &mut [f64], c: f64, v: &[f64]);
    /// `vₖᵀ·aᵦ` for two vectors and two columns, `[k][b]`.
    fn dots_2x2(self, v: [&[f64]; 2], a: [&[f64]; 2]) -> [[f64; 2]; 2];
    /// `x[i] = (x[i] − c₀·v₀[i]) − c₁·v₁[i]`.
    fn sub_scaled_2(self, x: &mut [f64], c: [f64; 2], v: [&[f64]; 2]);
    /// The plane rotation `(x[i], y[i]) ← (c·x[i] − s·y[i], s·x[i] + c·y[i])`.
    fn rotate(self, x: &mut [f64], y: &mut [f64], c: f64, s: f64);
    /// `out[i] += Σₜ c[t]·columns[t·ld + i]`, the terms added in order, for
    /// any length of `out`: a linear combination of columns of a column-major
    /// matrix (leading dimension `ld`), kept in registers across the terms.
    fn combine(self, out: &mut [f64], c: &[f64], columns: &[f64], ld: usize);
    /// `dst = srcᵀ`, for `src` of `rows × cols` (column-major, leading
    /// dimension `lds`) and `dst` of `cols × rows` (leading dimension `ldd`).
    fn transpose(self, src: &[f64], lds: usize, rows: usize, cols: usize, dst: &mut [f64], ldd: usize);
}

/// The lanes' sum in a fixed (pairwise) order.
#[inline(always)]
fn sum_lanes(acc: &Chunk) -> f64 {
    ((acc[0] + acc[4]) + (acc[2] + acc[6])) + ((acc[1] + acc[5]) + (acc[3] + acc[7]))
}

/// The slice `columns` must reach for `terms` columns of `len` entries.
#[inline(always)]
fn check_columns(terms: usize, len: usize, columns: &[f64], ld: usize) {
    assert!(
        terms == 0 || columns.len() >= (terms - 1) * ld + len,
        "combine: {terms} columns of {len} with leading dimension {ld} need more than {} values",
        columns.len()
    );
}

/// The slices a transpose reaches must hold the matrices.
#[inline(always)]
fn check_transpose(src: &[f64], lds: usize, rows: usize, cols: usize, dst: &[f64], ldd: usize) {
    assert!(
        rows == 0
            || cols == 0
            || (rows <= lds
                && cols <= ldd
                && src.len() >= (cols - 1) * lds + rows
                && dst.len() >= (rows - 1) * ldd + cols),
        "transpose: {rows} × {cols} does not fit {} values (ld {lds}) into {} (ld {ldd})",
        src.len(),
        dst.len()
    );
}

/// Plain Rust loops, for any CPU.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Portable;

impl Portable {
    /// Per-lane sums of `a[i]·b[i]`.
    #[inline(always)]
    fn product(a: &[f64], b: &[f64]) -> Chunk {
        let mut acc = [0.0; LANES];
        for (x, y) in a.chunks_exact(LANES).zip(b.chunks_exact(LANES)) {
            for l in 0..LANES {
                acc[l] += x[l] * y[l];
            }
        }
        acc
    }
}

impl Lanes for Portable {
    #[inline(always)]
    fn dots(self, v: &[f64], c: [&[f64]; COLUMN_BLOCK]) -> [f64; COLUMN_BLOCK] {
        c.map(|c| sum_lanes(&Self::product(v, c)))
    }

    #[inline(always)]
    fn dot(self, a: &[f64], b: &[f64]) -> f64 {
        sum_lanes(&Self::product(a, b))
    }

    #[inline(always)]
    fn sub_scaled(self, x: &mut [f64], c: f64, v: &[f64]) {
        for (x, v) in x.chunks_exact_mut(LANES).zip(v.chunks_exact(LANES)) {
            for l in 0..LANES {
                x[l] -= c * v[l];
            }
        }
    }

    #[inline(always)]
    fn dots_2x2(self, v: [&[f64]; 2], a: [&[f64]; 2]) -> [[f64; 2]; 2] {
        [[self.dot(v[0], a[0]), self.dot(v[0], a[1])], [self.dot(v[1], a[0]), self.dot(v[1], a[1])]]
    }

    #[inline(always)]
    fn sub_scaled_2(self, x: &mut [f64], c: [f64; 2], v: [&[f64]; 2]) {
        let chunks = x.chunks_exact_mut(LANES).zip(v[0].chunks_exact(LANES).zip(v[1].chunks_exact(LANES)));
        for (x, (v0, v1)) in chunks {
            for l in 0..LANES {
                x[l] = (x[l] - c[0] * v0[l]) - c[1] * v1[l];
            }
        }
    }

    #[inline(always)]
    fn rotate(self, x: &mut [f64], y: &mut [f64], c: f64, s: f64) {
        for (x, y) in x.chunks_exact_mut(LANES).zip(y.chunks_exact_mut(LANES)) {
            for l in 0..LANES {
                (x[l], y[l]) = (c * x[l] - s * y[l], s * x[l] + c * y[l]);
            }
        }
    }

    #[inline(always)]
    fn combine(self, out: &mut [f64], c: &[f64], columns: &[f64], ld: usize) {
        let len = out.len();
        check_columns(c.len(), len, columns, ld);
        for (t, &ct) in c.iter().enumerate() {
            for (o, &v) in out.iter_mut().zip(&columns[t * ld..t * ld + len]) {
                *o += ct * v;
            }
        }
    }

    #[inline(always)]
    fn transpose(self, src: &[f64], lds: usize, rows: usize, cols: usize, dst: &mut [f64], ldd: usize) {
        check_transpose(src, lds, rows, cols, dst, ldd);
        for j in 0..cols {
            for (i, &v) in src[j * lds..j * lds + rows].iter().enumerate() {
                dst[i * ldd + j] = v;
            }
        }
    }
}

#[cfg(target_arch = "x86_64")]
pub(crate) use avx2::Avx2;

/// Runs a function body compiled with AVX2 and FMA enabled when the CPU has
/// them (and the portable kernels are not forced, see `dispatch.rs`), and the
/// same body compiled for the baseline CPU otherwise; the body
/// gets the matching [`Lanes`] (`lanes`) for its kernels. Everything the body
/// inlines (the plain loops of a filter step, a model's block methods marked
/// `#[inline]`) is then vectorised with AVX2.
///
/// ```text
/// with_avx2!(fn<M: Model>(lanes, filter: &mut SquareRootCubature<M> = self, z: &[f64] = z) -> Result<(), FilterError> {
///     filter.update_body(lanes, z)
/// })
/// ```
macro_rules! with_avx2 {
    (fn<$($g:ident: $bound:path),*>($lanes:ident, $($arg:ident: $t:ty = $val:expr),*) -> $ret:ty $body:block) => {{
        #[inline(always)]
        fn body<Kernels: $crate::linalg::Lanes, $($g: $bound),*>($lanes: Kernels, $($arg: $t),*) -> $ret $body
        #[cfg(target_arch = "x86_64")]
        let result = if let Some(avx2) = $crate::linalg::Avx2::selected() {
            #[target_feature(enable = "avx2,fma")]
            fn run<$($g: $bound),*>(avx2: $crate::linalg::Avx2, $($arg: $t),*) -> $ret {
                body(avx2, $($arg),*)
            }
            #[allow(unsafe_code)]
            // SAFETY: an `Avx2` exists only on a CPU with AVX2 and FMA.
            unsafe {
                run(avx2, $($val),*)
            }
        } else {
            body($crate::linalg::Portable, $($val),*)
        };
        #[cfg(not(target_arch = "x86_64"))]
        let result = body($crate::linalg::Portable, $($val),*);
        result
    }};
}
pub(crate) use with_avx2;

#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
mod avx2 {
    use std::arch::x86_64::{
        __m256d, _mm256_add_pd, _mm256_castpd256_pd128, _mm256_cmpgt_epi64, _mm256_extractf128_pd, _mm256_fmadd_pd,
        _mm256_fmsub_pd, _mm256_fnmadd_pd, _mm256_hadd_pd, _mm256_loadu_pd, _mm256_maskload_pd, _mm256_maskstore_pd,
        _mm256_mul_pd, _mm256_permute2f128_pd, _mm256_set1_epi64x, _mm256_set1_pd, _mm256_setr_epi64x,
        _mm256_setzero_pd, _mm256_storeu_pd, _mm256_unpackhi_pd, _mm256_unpacklo_pd, _mm_add_pd, _mm_cvtsd_f64,
        _mm_unpackhi_pd,
    };

    use super::{check_columns, check_transpose, Chunk, Lanes, COLUMN_BLOCK, LANES};

    /// Proof that the CPU has AVX2 and FMA: only [`Avx2::detect`] makes one.
    #[derive(Debug, Clone, Copy)]
    pub(crate) struct Avx2(());

    impl Avx2 {
        /// `Some` on a CPU with AVX2 and FMA.
        pub(crate) fn detect() -> Option<Self> {
            (std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma"))
                .then_some(Self(()))
        }

        /// What a filter step runs on: `Some` when the CPU has AVX2 and FMA
        /// and the portable kernels are not forced (see `dispatch.rs`).
        #[inline(always)]
        pub(crate) fn selected() -> Option<Self> {
            // The choice is AVX2 only where `detect` found it.
            (crate::linalg::dispatch::choice() == crate::linalg::Kernels::Avx2).then_some(Self(()))
        }
    }

    impl Lanes for Avx2 {
        #[inline(always)]
        fn dots(self, v: &[f64], c: [&[f64]; COLUMN_BLOCK]) -> [f64; COLUMN_BLOCK] {
            // SAFETY: `self` exists, so the CPU has AVX2 and FMA.
            unsafe { dots(v, c) }
        }

        #[inline(always)]
        fn dot(self, a: &[f64], b: &[f64]) -> f64 {
            // SAFETY: as above.
            unsafe { dot(a, b) }
        }

        #[inline(always)]
        fn sub_scaled(self, x: &mut [f64], c: f64, v: &[f64]) {
            // SAFETY: as above.
            unsafe { sub_scaled(x, c, v) }
        }

        #[inline(always)]
        fn dots_2x2(self, v: [&[f64]; 2], a: [&[f64]; 2]) -> [[f64; 2]; 2] {
            // SAFETY: as above.
            unsafe { dots_2x2(v, a) }
        }

        #[inline(always)]
        fn sub_scaled_2(self, x: &mut [f64], c: [f64; 2], v: [&[f64]; 2]) {
            // SAFETY: as above.
            unsafe { sub_scaled_2(x, c, v) }
        }

        #[inline(always)]
        fn rotate(self, x: &mut [f64], y: &mut [f64], c: f64, s: f64) {
            // SAFETY: as above.
            unsafe { rotate(x, y, c, s) }
        }

        #[inline(always)]
        fn combine(self, out: &mut [f64], c: &[f64], columns: &[f64], ld: usize) {
            // SAFETY: as above.
            unsafe { combine(out, c, columns, ld) }
        }

        #[inline(always)]
        fn transpose(self, src: &[f64], lds: usize, rows: usize, cols: usize, dst: &mut [f64], ldd: usize) {
            // SAFETY: as above.
            unsafe { transpose(src, lds, rows, cols, dst, ldd) }
        }
    }

    /// A chunk as two registers.
    type Pair = (__m256d, __m256d);

    #[inline]
    #[target_feature(enable = "avx2,fma")]
    fn load(x: &[f64]) -> Pair {
        let x: &Chunk = x.try_into().expect("a whole chunk");
        // SAFETY: `x` holds 8 f64, so both unaligned 4-lane loads stay inside it.
        unsafe { (_mm256_loadu_pd(x.as_ptr()), _mm256_loadu_pd(x.as_ptr().add(4))) }
    }

    #[inline]
    #[target_feature(enable = "avx2,fma")]
    fn store(x: &mut [f64], (lo, hi): Pair) {
        let x: &mut Chunk = x.try_into().expect("a whole chunk");
        // SAFETY: `x` holds 8 f64, so both unaligned 4-lane stores stay inside it.
        unsafe {
            _mm256_storeu_pd(x.as_mut_ptr(), lo);
            _mm256_storeu_pd(x.as_mut_ptr().add(4), hi);
        }
    }

    /// `acc + a·b`, fused, lane by lane.
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    fn mul_add(acc: Pair, a: Pair, b: Pair) -> Pair {
        (_mm256_fmadd_pd(a.0, b.0, acc.0), _mm256_fmadd_pd(a.1, b.1, acc.1))
    }

    /// `x − c·v`, fused, lane by lane.
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    fn sub_mul(x: Pair, c: __m256d, v: Pair) -> Pair {
        (_mm256_fnmadd_pd(c, v.0, x.0), _mm256_fnmadd_pd(c, v.1, x.1))
    }

    #[inline]
    #[target_feature(enable = "avx2,fma")]
    fn zero() -> Pair {
        (_mm256_setzero_pd(), _mm256_setzero_pd())
    }

    /// The sums of the lanes of four accumulators, in registers.
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    fn sums4(acc: [Pair; 4]) -> [f64; 4] {
        let [a, b, c, d] = acc;
        let (a, b, c, d) =
            (_mm256_add_pd(a.0, a.1), _mm256_add_pd(b.0, b.1), _mm256_add_pd(c.0, c.1), _mm256_add_pd(d.0, d.1));
        // [a₀+a₁, b₀+b₁, a₂+a₃, b₂+b₃] and the same for c, d.
        let (ab, cd) = (_mm256_hadd_pd(a, b), _mm256_hadd_pd(c, d));
        let sums = _mm256_add_pd(_mm256_permute2f128_pd(ab, cd, 0x20), _mm256_permute2f128_pd(ab, cd, 0x31));
        let mut out = [0.0; 4];
        // SAFETY: `out` holds 4 f64.
        unsafe { _mm256_storeu_pd(out.as_mut_ptr(), sums) };
        out
    }

    /// The sum of the lanes of one accumulator.
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    fn sum1((lo, hi): Pair) -> f64 {
        let x = _mm256_add_pd(lo, hi);
        let half = _mm_add_pd(_mm256_castpd256_pd128(x), _mm256_extractf128_pd(x, 1));
        _mm_cvtsd_f64(_mm_add_pd(half, _mm_unpackhi_pd(half, half)))
    }

    #[inline]
    #[target_feature(enable = "avx2,fma")]
    fn dots(v: &[f64], c: [&[f64]; COLUMN_BLOCK]) -> [f64; COLUMN_BLOCK] {
        let mut acc = [zero(); COLUMN_BLOCK];
        for (i, vi) in v.chunks_exact(LANES).enumerate() {
            let vi = load(vi);
            for (acc, c) in acc.iter_mut().zip(&c) {
                *acc = mul_add(*acc, vi, load(&c[i * LANES..(i + 1) * LANES]));
            }
        }
        sums4(acc)
    }

    #[inline]
    #[target_feature(enable = "avx2,fma")]
    fn dot(a: &[f64], b: &[f64]) -> f64 {
        let mut acc = zero();
        for (x, y) in a.chunks_exact(LANES).zip(b.chunks_exact(LANES)) {
            acc = mul_add(acc, load(x), load(y));
        }
        sum1(acc)
    }

    #[inline]
    #[target_feature(enable = "avx2,fma")]
    fn dots_2x2(v: [&[f64]; 2], a: [&[f64]; 2]) -> [[f64; 2]; 2] {
        let mut acc = [zero(); 4];
        let chunks = v[0].chunks_exact(LANES).zip(v[1].chunks_exact(LANES));
        let chunks = chunks.zip(a[0].chunks_exact(LANES).zip(a[1].chunks_exact(LANES)));
        for ((v0, v1), (a0, a1)) in chunks {
            let (v0, v1, a0, a1) = (load(v0), load(v1), load(a0), load(a1));
            acc[0] = mul_add(acc[0], v0, a0);
            acc[1] = mul_add(acc[1], v0, a1);
            acc[2] = mul_add(acc[2], v1, a0);
            acc[3] = mul_add(acc[3], v1, a1);
        }
        let [s00, s01, s10, s11] = sums4(acc);
        [[s00, s01], [s10, s11]]
    }

    #[inline]
    #[target_feature(enable = "avx2,fma")]
    fn sub_scaled_2(x: &mut [f64], c: [f64; 2], v: [&[f64]; 2]) {
        let (c0, c1) = (_mm256_set1_pd(c[0]), _mm256_set1_pd(c[1]));
        let chunks = x.chunks_exact_mut(LANES).zip(v[0].chunks_exact(LANES).zip(v[1].chunks_exact(LANES)));
        for (x, (v0, v1)) in chunks {
            let once = sub_mul(load(x), c0, load(v0));
            store(x, sub_mul(once, c1, load(v1)));
        }
    }

    #[inline]
    #[target_feature(enable = "avx2,fma")]
    fn sub_scaled(x: &mut [f64], c: f64, v: &[f64]) {
        let c = _mm256_set1_pd(c);
        for (x, v) in x.chunks_exact_mut(LANES).zip(v.chunks_exact(LANES)) {
            store(x, sub_mul(load(x), c, load(v)));
        }
    }

    #[inline]
    #[target_feature(enable = "avx2,fma")]
    fn rotate(x: &mut [f64], y: &mut [f64], c: f64, s: f64) {
        let (c, s) = (_mm256_set1_pd(c), _mm256_set1_pd(s));
        for (x, y) in x.chunks_exact_mut(LANES).zip(y.chunks_exact_mut(LANES)) {
            let (xv, yv) = (load(x), load(y));
            // c·x − s·y and s·x + c·y, each with one product fused.
            let xr =
                (_mm256_fmsub_pd(c, xv.0, _mm256_mul_pd(s, yv.0)), _mm256_fmsub_pd(c, xv.1, _mm256_mul_pd(s, yv.1)));
            let yr =
                (_mm256_fmadd_pd(s, xv.0, _mm256_mul_pd(c, yv.0)), _mm256_fmadd_pd(s, xv.1, _mm256_mul_pd(c, yv.1)));
            store(x, xr);
            store(y, yr);
        }
    }

    /// `R` registers of `out` from `at`, with every term added in them, in order. The
    /// last register holds only its first `last` lanes (1 to 4), loaded and stored
    /// masked, so that any length is whole registers: a scalar tail would add its terms
    /// one after the other in a single chain, each waiting for the last fused add.
    ///
    /// # Safety
    /// `out[at..at + 4(R − 1) + last]` and `columns[t·ld + at..t·ld + at + 4(R − 1) + last]`
    /// for every term `t < c.len()` lie inside their slices; `1 ≤ last ≤ 4`.
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn combine_registers<const R: usize>(
        out: &mut [f64],
        at: usize,
        c: &[f64],
        columns: &[f64],
        ld: usize,
        last: usize,
    ) {
        let (o, p) = (out.as_mut_ptr(), columns.as_ptr());
        let mask = _mm256_cmpgt_epi64(_mm256_set1_epi64x(last as i64), _mm256_setr_epi64x(0, 1, 2, 3));
        let tail = 4 * (R - 1);
        // SAFETY: the caller's bounds; the masked lanes are neither read nor written.
        unsafe {
            // Loops, not `array::from_fn`: a closure would be compiled without AVX2.
            let mut acc = [_mm256_setzero_pd(); R];
            for (r, acc) in acc[..R - 1].iter_mut().enumerate() {
                *acc = _mm256_loadu_pd(o.add(at + 4 * r));
            }
            acc[R - 1] = _mm256_maskload_pd(o.add(at + tail), mask);
            for (t, &ct) in c.iter().enumerate() {
                let ct = _mm256_set1_pd(ct);
                let col = p.add(t * ld + at);
                for (r, acc) in acc[..R - 1].iter_mut().enumerate() {
                    *acc = _mm256_fmadd_pd(ct, _mm256_loadu_pd(col.add(4 * r)), *acc);
                }
                acc[R - 1] = _mm256_fmadd_pd(ct, _mm256_maskload_pd(col.add(tail), mask), acc[R - 1]);
            }
            for (r, acc) in acc[..R - 1].iter().enumerate() {
                _mm256_storeu_pd(o.add(at + 4 * r), *acc);
            }
            _mm256_maskstore_pd(o.add(at + tail), mask, acc[R - 1]);
        }
    }

    /// Up to 32 entries (8 registers) at a time: the registers' chains of fused adds
    /// are independent, and the more of them run at once, the less each term waits.
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    fn combine(out: &mut [f64], c: &[f64], columns: &[f64], ld: usize) {
        let len = out.len();
        check_columns(c.len(), len, columns, ld);
        let mut at = 0;
        while len - at > 32 {
            // SAFETY (here and below): `at + 4R ≤ len` (the last register's `last`
            // lanes for the final call), and `check_columns` holds.
            unsafe { combine_registers::<8>(out, at, c, columns, ld, 4) };
            at += 32;
        }
        let rest = len - at;
        if rest == 0 {
            return;
        }
        let registers = rest.div_ceil(4);
        let last = rest - 4 * (registers - 1);
        // SAFETY: as above.
        unsafe {
            match registers {
                1 => combine_registers::<1>(out, at, c, columns, ld, last),
                2 => combine_registers::<2>(out, at, c, columns, ld, last),
                3 => combine_registers::<3>(out, at, c, columns, ld, last),
                4 => combine_registers::<4>(out, at, c, columns, ld, last),
                5 => combine_registers::<5>(out, at, c, columns, ld, last),
                6 => combine_registers::<6>(out, at, c, columns, ld, last),
                7 => combine_registers::<7>(out, at, c, columns, ld, last),
                _ => combine_registers::<8>(out, at, c, columns, ld, last),
            }
        }
    }

    #[inline]
    #[target_feature(enable = "avx2,fma")]
    fn transpose(src: &[f64], lds: usize, rows: usize, cols: usize, dst: &mut [f64], ldd: usize) {
        check_transpose(src, lds, rows, cols, dst, ldd);
        let (whole_rows, whole_cols) = (rows - rows % 4, cols - cols % 4);
        let (s, d) = (src.as_ptr(), dst.as_mut_ptr());
        for j in (0..whole_cols).step_by(4) {
            for i in (0..whole_rows).step_by(4) {
                // SAFETY: rows i..i+4 of columns j..j+4 lie inside `src`, and
                // rows j..j+4 of columns i..i+4 inside `dst` (`check_transpose`).
                unsafe {
                    let c0 = _mm256_loadu_pd(s.add(j * lds + i));
                    let c1 = _mm256_loadu_pd(s.add((j + 1) * lds + i));
                    let c2 = _mm256_loadu_pd(s.add((j + 2) * lds + i));
                    let c3 = _mm256_loadu_pd(s.add((j + 3) * lds + i));
                    // [c0ᵢ, c1ᵢ, c0ᵢ₊₂, c1ᵢ₊₂] and so on: then swap the 128-bit halves.
                    let (t0, t1) = (_mm256_unpacklo_pd(c0, c1), _mm256_unpackhi_pd(c0, c1));
                    let (t2, t3) = (_mm256_unpacklo_pd(c2, c3), _mm256_unpackhi_pd(c2, c3));
                    _mm256_storeu_pd(d.add(i * ldd + j), _mm256_permute2f128_pd(t0, t2, 0x20));
                    _mm256_storeu_pd(d.add((i + 1) * ldd + j), _mm256_permute2f128_pd(t1, t3, 0x20));
                    _mm256_storeu_pd(d.add((i + 2) * ldd + j), _mm256_permute2f128_pd(t0, t2, 0x31));
                    _mm256_storeu_pd(d.add((i + 3) * ldd + j), _mm256_permute2f128_pd(t1, t3, 0x31));
                }
            }
            for i in whole_rows..rows {
                for jj in j..j + 4 {
                    dst[i * ldd + jj] = src[jj * lds + i];
                }
            }
        }
        for j in whole_cols..cols {
            for (i, &v) in src[j * lds..j * lds + rows].iter().enumerate() {
                dst[i * ldd + j] = v;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn data(len: usize, seed: u64) -> Vec<f64> {
        (0..len).map(|i| ((i as u64 * 2654435761 + seed * 97) % 1000) as f64 / 37.0 - 13.0).collect()
    }

    /// `a` and `b` agree to rounding, relative to the size of what was summed.
    fn close(a: &[f64], b: &[f64], scale: f64) -> bool {
        a.len() == b.len() && a.iter().zip(b).all(|(x, y)| (x - y).abs() <= 1e-14 * scale)
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn avx2_agrees_with_portable_to_rounding() {
        let Some(avx2) = Avx2::detect() else {
            eprintln!("no AVX2 and FMA on this CPU: only the portable path runs here");
            return;
        };
        for chunks in [1, 3, 7] {
            let len = chunks * LANES;
            // |entries| ≤ 14, so sums of `len` products stay below 200·len.
            let scale = 200.0 * len as f64;
            let v = data(len, 1);
            let cols: Vec<Vec<f64>> = (0..COLUMN_BLOCK as u64).map(|b| data(len, b + 2)).collect();
            let c: [&[f64]; COLUMN_BLOCK] = std::array::from_fn(|b| cols[b].as_slice());
            assert!(close(&avx2.dots(&v, c), &Portable.dots(&v, c), scale));
            assert!(close(&[avx2.dot(&v, &cols[0])], &[Portable.dot(&v, &cols[0])], scale));
            let (mut x1, mut x2) = (cols[1].clone(), cols[1].clone());
            avx2.sub_scaled(&mut x1, 0.37, &v);
            Portable.sub_scaled(&mut x2, 0.37, &v);
            assert!(close(&x1, &x2, 20.0));
            let (v2, a2) = ([v.as_slice(), c[1]], [c[2], c[3]]);
            let (d1, d2) = (avx2.dots_2x2(v2, a2), Portable.dots_2x2(v2, a2));
            assert!(close(d1.as_flattened(), d2.as_flattened(), scale));
            let (mut x1, mut x2) = (cols[0].clone(), cols[0].clone());
            avx2.sub_scaled_2(&mut x1, [0.37, -1.3], v2);
            Portable.sub_scaled_2(&mut x2, [0.37, -1.3], v2);
            assert!(close(&x1, &x2, 40.0));
            let (mut x1, mut y1, mut x2, mut y2) = (cols[0].clone(), cols[1].clone(), cols[0].clone(), cols[1].clone());
            let (c, s) = (0.6, -0.8);
            avx2.rotate(&mut x1, &mut y1, c, s);
            Portable.rotate(&mut x2, &mut y2, c, s);
            assert!(close(&x1, &x2, 20.0) && close(&y1, &y2, 20.0));
        }
        // Every length, so that each register count and each masked last register run.
        for len in 0..80 {
            let ld = len + 3;
            let columns = data(5 * ld, 9);
            let c = [0.5, -1.25, 3.0, 0.0, -0.75];
            // `out` is followed by sentinels that a masked lane must not touch.
            let mut x1: Vec<f64> = data(len, 4).into_iter().chain([f64::NAN; 4]).collect();
            let mut x2 = data(len, 4);
            avx2.combine(&mut x1[..len], &c, &columns, ld);
            Portable.combine(&mut x2, &c, &columns, ld);
            assert!(close(&x1[..len], &x2, 100.0), "len {len}");
            assert!(x1[len..].iter().all(|v| v.is_nan()), "len {len}: wrote past the end");
            // Each entry is its terms fused in order, one chain per entry, to the bit.
            let mut fused = data(len, 4);
            for (i, o) in fused.iter_mut().enumerate() {
                for (t, &ct) in c.iter().enumerate() {
                    *o = ct.mul_add(columns[t * ld + i], *o);
                }
            }
            assert_eq!(&x1[..len], fused.as_slice(), "len {len}");
        }
    }

    fn check_transposes<L: Lanes>(lanes: L) {
        for (rows, cols) in [(0, 3), (1, 1), (3, 5), (4, 4), (7, 9), (24, 24), (9, 8)] {
            let (lds, ldd) = (rows + 2, cols + 1);
            let src = data(lds * cols, 3);
            let mut dst = vec![f64::NAN; ldd * rows.max(1)];
            lanes.transpose(&src, lds, rows, cols, &mut dst, ldd);
            for i in 0..rows {
                for j in 0..cols {
                    assert_eq!(dst[i * ldd + j], src[j * lds + i], "{rows} × {cols} at ({i}, {j})");
                }
                assert!(dst[i * ldd + cols].is_nan(), "{rows} × {cols}: wrote past row {i}");
            }
        }
    }

    #[test]
    fn transposes_are_exact_at_every_shape() {
        check_transposes(Portable);
        #[cfg(target_arch = "x86_64")]
        if let Some(avx2) = Avx2::detect() {
            check_transposes(avx2);
        }
    }

    #[test]
    fn kernels_compute_what_they_say() {
        let (a, b) = (data(16, 1), data(16, 2));
        let total: f64 = a.iter().zip(&b).map(|(x, y)| x * y).sum();
        assert!((Portable.dot(&a, &b) - total).abs() < 1e-12 * total.abs().max(1.0));
        // combine: out + Σ c[t]·column t, columns 4 apart with 3-entry columns.
        let columns: Vec<f64> = (0..12).map(f64::from).collect();
        let mut out = [1.0, 2.0, 3.0];
        Portable.combine(&mut out, &[2.0, -1.0, 0.5], &columns, 4);
        assert_eq!(out, [1.0 + 0.0 - 4.0 + 4.0, 2.0 + 2.0 - 5.0 + 4.5, 3.0 + 4.0 - 6.0 + 5.0]);
        // rotate: (x, y) ← (c·x − s·y, s·x + c·y), here with c = 0, s = 1.
        let (mut x, mut y) = (a.clone(), b.clone());
        Portable.rotate(&mut x, &mut y, 0.0, 1.0);
        assert_eq!((x, y), (b.iter().map(|v| -v).collect(), a));
    }

    #[test]
    #[should_panic(expected = "combine: 3 columns of 3")]
    fn combine_refuses_columns_that_are_too_short() {
        Portable.combine(&mut [0.0; 3], &[1.0; 3], &[0.0; 10], 4);
    }
}
