//! The inner loops of the dense kernels over chunks of [`LANES`] `f64`, in two
//! implementations: portable Rust, and AVX2 intrinsics chosen at run time.
//!
//! Both do the same roundings in the same order (a product, then a sum, per
//! lane; no fused multiply-add; lanes summed in a fixed order), so a filter
//! gives bit-for-bit the same numbers on every x86-64 CPU, with or without AVX2.
//! The compiler's own vectoriser, given the same loops under AVX2, packs
//! across columns with shuffles: it took 2.2× the instructions of these
//! intrinsics for the Householder QR (callgrind, `examples/step_loop.rs`).
//!
//! The AVX2 implementation is reached only through an [`Avx2`] token, which
//! exists only on a CPU that has AVX2; that is what makes its calls sound.

/// `f64` per chunk: two AVX2 registers.
pub(crate) const LANES: usize = 8;

/// Columns whose products with one vector are formed in one pass over it.
pub(crate) const COLUMN_BLOCK: usize = 4;

/// One chunk of lanes.
pub(crate) type Chunk = [f64; LANES];

/// The inner loops. Slices are whole numbers of chunks (their length a
/// multiple of [`LANES`]); `a` and `v` have equal lengths.
pub(crate) trait Lanes: Copy {
    /// Per-lane sums of `v[i]·cᵦ[i]` for [`COLUMN_BLOCK`] columns.
    fn products(self, v: &[f64], c: [&[f64]; COLUMN_BLOCK]) -> [Chunk; COLUMN_BLOCK];
    /// Per-lane sums of `a[i]·b[i]`.
    fn product(self, a: &[f64], b: &[f64]) -> Chunk;
    /// `x[i] −= c·v[i]`.
    fn sub_scaled(self, x: &mut [f64], c: f64, v: &[f64]);
    /// Per-lane sums of `vₖ[i]·aᵦ[i]` for two vectors and two columns, `[k][b]`.
    fn products_2x2(self, v: [&[f64]; 2], a: [&[f64]; 2]) -> [[Chunk; 2]; 2];
    /// `x[i] = (x[i] − c₀·v₀[i]) − c₁·v₁[i]`.
    fn sub_scaled_2(self, x: &mut [f64], c: [f64; 2], v: [&[f64]; 2]);
}

/// The lanes' sum in a fixed (pairwise) order.
#[inline(always)]
pub(crate) fn sum_lanes(acc: &Chunk) -> f64 {
    ((acc[0] + acc[4]) + (acc[2] + acc[6])) + ((acc[1] + acc[5]) + (acc[3] + acc[7]))
}

/// Plain Rust loops, for any CPU.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Portable;

impl Lanes for Portable {
    #[inline(always)]
    fn products(self, v: &[f64], c: [&[f64]; COLUMN_BLOCK]) -> [Chunk; COLUMN_BLOCK] {
        c.map(|c| self.product(v, c))
    }

    #[inline(always)]
    fn product(self, a: &[f64], b: &[f64]) -> Chunk {
        let mut acc = [0.0; LANES];
        for (x, y) in a.chunks_exact(LANES).zip(b.chunks_exact(LANES)) {
            for l in 0..LANES {
                acc[l] += x[l] * y[l];
            }
        }
        acc
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
    fn products_2x2(self, v: [&[f64]; 2], a: [&[f64]; 2]) -> [[Chunk; 2]; 2] {
        [[self.product(v[0], a[0]), self.product(v[0], a[1])], [self.product(v[1], a[0]), self.product(v[1], a[1])]]
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
}

#[cfg(target_arch = "x86_64")]
pub(crate) use avx2::Avx2;

/// Runs a function body compiled with AVX2 enabled when the CPU has it, and
/// the same body compiled for the baseline CPU otherwise. Everything the body
/// inlines (the plain loops of a filter step, a model's block methods marked
/// `#[inline]`) is then vectorised with AVX2; the arithmetic and its order
/// are the same in both, so the results are too.
///
/// ```text
/// with_avx2!(fn<M: Model>(filter: &mut SquareRootCubature<M> = self, z: &[f64] = z) -> Result<(), FilterError> {
///     filter.update_body(z)
/// })
/// ```
macro_rules! with_avx2 {
    (fn<$($g:ident: $bound:path),*>($($arg:ident: $t:ty = $val:expr),*) -> $ret:ty $body:block) => {{
        #[inline(always)]
        fn body<$($g: $bound),*>($($arg: $t),*) -> $ret $body
        #[cfg(target_arch = "x86_64")]
        let result = if let Some(avx2) = $crate::linalg::Avx2::detect() {
            #[target_feature(enable = "avx2")]
            fn run<$($g: $bound),*>(_: $crate::linalg::Avx2, $($arg: $t),*) -> $ret {
                body($($arg),*)
            }
            #[allow(unsafe_code)]
            // SAFETY: an `Avx2` exists only on a CPU with AVX2.
            unsafe {
                run(avx2, $($val),*)
            }
        } else {
            body($($val),*)
        };
        #[cfg(not(target_arch = "x86_64"))]
        let result = body($($val),*);
        result
    }};
}
pub(crate) use with_avx2;

#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
mod avx2 {
    use std::arch::x86_64::{
        __m256d, _mm256_add_pd, _mm256_loadu_pd, _mm256_mul_pd, _mm256_set1_pd, _mm256_setzero_pd, _mm256_storeu_pd,
        _mm256_sub_pd,
    };

    use super::{Chunk, Lanes, COLUMN_BLOCK, LANES};

    /// Proof that the CPU has AVX2: only [`Avx2::detect`] makes one.
    #[derive(Debug, Clone, Copy)]
    pub(crate) struct Avx2(());

    impl Avx2 {
        /// `Some` on a CPU with AVX2.
        pub(crate) fn detect() -> Option<Self> {
            std::arch::is_x86_feature_detected!("avx2").then_some(Self(()))
        }
    }

    impl Lanes for Avx2 {
        #[inline(always)]
        fn products(self, v: &[f64], c: [&[f64]; COLUMN_BLOCK]) -> [Chunk; COLUMN_BLOCK] {
            // SAFETY: `self` exists, so the CPU has AVX2.
            unsafe { products(v, c) }
        }

        #[inline(always)]
        fn product(self, a: &[f64], b: &[f64]) -> Chunk {
            // SAFETY: as above.
            unsafe { product(a, b) }
        }

        #[inline(always)]
        fn sub_scaled(self, x: &mut [f64], c: f64, v: &[f64]) {
            // SAFETY: as above.
            unsafe { sub_scaled(x, c, v) }
        }

        #[inline(always)]
        fn products_2x2(self, v: [&[f64]; 2], a: [&[f64]; 2]) -> [[Chunk; 2]; 2] {
            // SAFETY: as above.
            unsafe { products_2x2(v, a) }
        }

        #[inline(always)]
        fn sub_scaled_2(self, x: &mut [f64], c: [f64; 2], v: [&[f64]; 2]) {
            // SAFETY: as above.
            unsafe { sub_scaled_2(x, c, v) }
        }
    }

    /// The two halves of a chunk.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn load(x: &[f64]) -> (__m256d, __m256d) {
        let x: &Chunk = x.try_into().expect("a whole chunk");
        // SAFETY: `x` holds 8 f64, so both unaligned 4-lane loads stay inside it.
        unsafe { (_mm256_loadu_pd(x.as_ptr()), _mm256_loadu_pd(x.as_ptr().add(4))) }
    }

    #[inline]
    #[target_feature(enable = "avx2")]
    fn store(x: &mut [f64], (lo, hi): (__m256d, __m256d)) {
        let x: &mut Chunk = x.try_into().expect("a whole chunk");
        // SAFETY: `x` holds 8 f64, so both unaligned 4-lane stores stay inside it.
        unsafe {
            _mm256_storeu_pd(x.as_mut_ptr(), lo);
            _mm256_storeu_pd(x.as_mut_ptr().add(4), hi);
        }
    }

    #[inline]
    #[target_feature(enable = "avx2")]
    fn to_chunk(acc: (__m256d, __m256d)) -> Chunk {
        let mut out = [0.0; LANES];
        store(&mut out, acc);
        out
    }

    #[inline]
    #[target_feature(enable = "avx2")]
    fn mul_add(acc: (__m256d, __m256d), a: (__m256d, __m256d), b: (__m256d, __m256d)) -> (__m256d, __m256d) {
        (_mm256_add_pd(acc.0, _mm256_mul_pd(a.0, b.0)), _mm256_add_pd(acc.1, _mm256_mul_pd(a.1, b.1)))
    }

    #[inline]
    #[target_feature(enable = "avx2")]
    fn products(v: &[f64], c: [&[f64]; COLUMN_BLOCK]) -> [Chunk; COLUMN_BLOCK] {
        let zero = (_mm256_setzero_pd(), _mm256_setzero_pd());
        let mut acc = [zero; COLUMN_BLOCK];
        for (i, vi) in v.chunks_exact(LANES).enumerate() {
            let vi = load(vi);
            for (acc, c) in acc.iter_mut().zip(&c) {
                *acc = mul_add(*acc, vi, load(&c[i * LANES..(i + 1) * LANES]));
            }
        }
        acc.map(|a| to_chunk(a))
    }

    #[inline]
    #[target_feature(enable = "avx2")]
    fn product(a: &[f64], b: &[f64]) -> Chunk {
        let mut acc = (_mm256_setzero_pd(), _mm256_setzero_pd());
        for (x, y) in a.chunks_exact(LANES).zip(b.chunks_exact(LANES)) {
            acc = mul_add(acc, load(x), load(y));
        }
        to_chunk(acc)
    }

    #[inline]
    #[target_feature(enable = "avx2")]
    fn products_2x2(v: [&[f64]; 2], a: [&[f64]; 2]) -> [[Chunk; 2]; 2] {
        let zero = (_mm256_setzero_pd(), _mm256_setzero_pd());
        let mut acc = [[zero; 2]; 2];
        let chunks = v[0].chunks_exact(LANES).zip(v[1].chunks_exact(LANES));
        let chunks = chunks.zip(a[0].chunks_exact(LANES).zip(a[1].chunks_exact(LANES)));
        for ((v0, v1), (a0, a1)) in chunks {
            let (v0, v1, a0, a1) = (load(v0), load(v1), load(a0), load(a1));
            acc[0][0] = mul_add(acc[0][0], v0, a0);
            acc[0][1] = mul_add(acc[0][1], v0, a1);
            acc[1][0] = mul_add(acc[1][0], v1, a0);
            acc[1][1] = mul_add(acc[1][1], v1, a1);
        }
        let mut out = [[[0.0; LANES]; 2]; 2];
        for (out, acc) in out.iter_mut().zip(&acc) {
            *out = [to_chunk(acc[0]), to_chunk(acc[1])];
        }
        out
    }

    #[inline]
    #[target_feature(enable = "avx2")]
    fn sub_scaled_2(x: &mut [f64], c: [f64; 2], v: [&[f64]; 2]) {
        let (c0, c1) = (_mm256_set1_pd(c[0]), _mm256_set1_pd(c[1]));
        let chunks = x.chunks_exact_mut(LANES).zip(v[0].chunks_exact(LANES).zip(v[1].chunks_exact(LANES)));
        for (x, (v0, v1)) in chunks {
            let (xv, v0, v1) = (load(x), load(v0), load(v1));
            let once = (_mm256_sub_pd(xv.0, _mm256_mul_pd(c0, v0.0)), _mm256_sub_pd(xv.1, _mm256_mul_pd(c0, v0.1)));
            store(x, (_mm256_sub_pd(once.0, _mm256_mul_pd(c1, v1.0)), _mm256_sub_pd(once.1, _mm256_mul_pd(c1, v1.1))));
        }
    }

    #[inline]
    #[target_feature(enable = "avx2")]
    fn sub_scaled(x: &mut [f64], c: f64, v: &[f64]) {
        let c = _mm256_set1_pd(c);
        for (x, v) in x.chunks_exact_mut(LANES).zip(v.chunks_exact(LANES)) {
            let (xv, vv) = (load(x), load(v));
            store(x, (_mm256_sub_pd(xv.0, _mm256_mul_pd(c, vv.0)), _mm256_sub_pd(xv.1, _mm256_mul_pd(c, vv.1))));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn data(len: usize, seed: u64) -> Vec<f64> {
        (0..len).map(|i| ((i as u64 * 2654435761 + seed * 97) % 1000) as f64 / 37.0 - 13.0).collect()
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn avx2_equals_portable_bit_for_bit() {
        let Some(avx2) = Avx2::detect() else {
            eprintln!("no AVX2 on this CPU: only the portable path runs here");
            return;
        };
        for chunks in [1, 3, 7] {
            let len = chunks * LANES;
            let v = data(len, 1);
            let cols: Vec<Vec<f64>> = (0..COLUMN_BLOCK as u64).map(|b| data(len, b + 2)).collect();
            let c: [&[f64]; COLUMN_BLOCK] = std::array::from_fn(|b| cols[b].as_slice());
            assert_eq!(avx2.products(&v, c), Portable.products(&v, c));
            assert_eq!(avx2.product(&v, &cols[0]), Portable.product(&v, &cols[0]));
            let (mut x1, mut x2) = (cols[1].clone(), cols[1].clone());
            avx2.sub_scaled(&mut x1, 0.37, &v);
            Portable.sub_scaled(&mut x2, 0.37, &v);
            assert_eq!(x1, x2);
            let (v2, a2) = ([v.as_slice(), c[1]], [c[2], c[3]]);
            assert_eq!(avx2.products_2x2(v2, a2), Portable.products_2x2(v2, a2));
            let (mut x1, mut x2) = (cols[0].clone(), cols[0].clone());
            avx2.sub_scaled_2(&mut x1, [0.37, -1.3], v2);
            Portable.sub_scaled_2(&mut x2, [0.37, -1.3], v2);
            assert_eq!(x1, x2);
        }
    }

    #[test]
    fn lanes_hold_the_per_lane_sums() {
        let (a, b) = (data(16, 1), data(16, 2));
        let acc = Portable.product(&a, &b);
        for l in 0..LANES {
            assert_eq!(acc[l], a[l] * b[l] + a[LANES + l] * b[LANES + l]);
        }
        let total: f64 = a.iter().zip(&b).map(|(x, y)| x * y).sum();
        assert!((sum_lanes(&acc) - total).abs() < 1e-12 * total.abs().max(1.0));
    }
}
