//! The elementary functions of the filters, the models and the truths, computed by Rust
//! code (the `libm` crate, a port of musl's) instead of the platform's C library. glibc,
//! mingw-w64's msvcrt and Apple's libm round `exp`, `sin`, `pow`, `cbrt` … differently in
//! the last bit, and a filter carries such a bit on: the same FMU would give other numbers
//! on Windows than on Linux. Through these, every platform computes the same bits, as every
//! platform already does for `+ − × ÷` and `sqrt` (IEEE 754). The crates that use them
//! deny the standard library's methods in their `clippy.toml`.

/// `eˣ`.
pub fn exp(x: f64) -> f64 {
    libm::exp(x)
}

/// `eˣ − 1`, accurate near 0.
pub fn exp_m1(x: f64) -> f64 {
    libm::expm1(x)
}

/// The natural logarithm.
pub fn ln(x: f64) -> f64 {
    libm::log(x)
}

/// `ln(1 + x)`, accurate near 0.
pub fn ln_1p(x: f64) -> f64 {
    libm::log1p(x)
}

/// The decimal logarithm.
pub fn log10(x: f64) -> f64 {
    libm::log10(x)
}

/// `xʸ`.
pub fn powf(x: f64, y: f64) -> f64 {
    libm::pow(x, y)
}

/// The cube root.
pub fn cbrt(x: f64) -> f64 {
    libm::cbrt(x)
}

/// The sine.
pub fn sin(x: f64) -> f64 {
    libm::sin(x)
}

/// The cosine.
pub fn cos(x: f64) -> f64 {
    libm::cos(x)
}

/// The sine and the cosine.
pub fn sin_cos(x: f64) -> (f64, f64) {
    libm::sincos(x)
}

/// The tangent.
pub fn tan(x: f64) -> f64 {
    libm::tan(x)
}

/// The arcsine.
pub fn asin(x: f64) -> f64 {
    libm::asin(x)
}

/// The arctangent.
pub fn atan(x: f64) -> f64 {
    libm::atan(x)
}

/// The four-quadrant arctangent of `y / x`.
pub fn atan2(y: f64, x: f64) -> f64 {
    libm::atan2(y, x)
}

#[cfg(test)]
#[allow(clippy::disallowed_methods, reason = "the comparison with the platform's functions")]
mod tests {
    use super::*;

    /// The same numbers as the C library's to within an ulp or two, which is all that
    /// changes: the bits no longer depend on the platform.
    #[test]
    fn each_function_is_the_usual_one_to_the_last_bits() {
        let close = |a: f64, b: f64| (a - b).abs() <= 4.0 * f64::EPSILON * a.abs().max(b.abs()).max(f64::MIN_POSITIVE);
        for x in [0.3, 1.7, -2.5, 10.0, 1e-8] {
            assert!(close(exp(x), x.exp()) && close(exp_m1(x), x.exp_m1()), "{x}");
            assert!(close(sin(x), x.sin()) && close(cos(x), x.cos()) && close(tan(x), x.tan()), "{x}");
            assert_eq!(sin_cos(x), (sin(x), cos(x)));
            assert!(close(atan(x), x.atan()) && close(atan2(x, 0.7), x.atan2(0.7)) && close(cbrt(x), x.cbrt()), "{x}");
            let y = x.abs();
            assert!(close(ln(y), y.ln()) && close(ln_1p(y), y.ln_1p()) && close(log10(y), y.log10()), "{x}");
            assert!(close(powf(y, 1.5), y.powf(1.5)) && close(asin(x / 11.0), (x / 11.0).asin()), "{x}");
        }
    }
}
