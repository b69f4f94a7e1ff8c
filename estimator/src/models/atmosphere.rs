//! The International Standard Atmosphere (ISO 2533), the layers a tactical missile flies
//! in: the troposphere to 11 km, the isothermal layer to 20 km, and the first layer of
//! the stratosphere, whose law is used beyond 32 km too (the model must stay defined
//! wherever a filter's sigma points wander).

use crate::math;

/// Sea-level temperature (K).
const T0: f64 = 288.15;
/// Sea-level pressure (Pa).
const P0: f64 = 101_325.0;
/// The specific gas constant of dry air (J/(kg·K)).
const R_AIR: f64 = 287.053;
/// `g₀/(R·L)` of the troposphere, its lapse rate 6.5 K/km.
const TROPOSPHERE_EXPONENT: f64 = 5.25588;
/// The isothermal layer's temperature (K) and its base pressure (Pa), at 11 km.
const T11: f64 = 216.65;
const P11: f64 = 22_632.06;
/// The base pressure at 20 km (Pa), and `g₀/(R·L)` above it (lapse −1 K/km).
const P20: f64 = 5_474.889;
const STRATOSPHERE_EXPONENT: f64 = 34.1632;
/// `g₀/R` (K/m): the isothermal layer's pressure scale.
const G0_OVER_R: f64 = 9.806_65 / R_AIR;

/// Temperature (K) at the geopotential altitude `h` (m).
pub fn temperature(h: f64) -> f64 {
    if h < 11_000.0 {
        T0 - 0.0065 * h
    } else if h < 20_000.0 {
        T11
    } else {
        T11 + 0.001 * (h - 20_000.0)
    }
}

/// Pressure (Pa) at `h` (m).
pub fn pressure(h: f64) -> f64 {
    let t = temperature(h);
    if h < 11_000.0 {
        P0 * math::powf(t / T0, TROPOSPHERE_EXPONENT)
    } else if h < 20_000.0 {
        P11 * math::exp(-G0_OVER_R / T11 * (h - 11_000.0))
    } else {
        P20 * math::powf(T11 / t, STRATOSPHERE_EXPONENT)
    }
}

/// Density (kg/m³) at `h` (m).
pub fn density(h: f64) -> f64 {
    pressure(h) / (R_AIR * temperature(h))
}

/// Speed of sound (m/s) at `h` (m).
pub fn speed_of_sound(h: f64) -> f64 {
    20.0468 * temperature(h).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn it_gives_the_standard_table() {
        // US 1976 at 0, 5, 10, 11, 15, 20, 25 km of geometric altitude z; this model
        // takes the geopotential altitude h = r₀·z/(r₀ + z).
        let geopotential = |z: f64| 6_356_766.0 * z / (6_356_766.0 + z);
        for (z, rho) in [
            (0.0, 1.2250),
            (5_000.0, 0.73643),
            (10_000.0, 0.41351),
            (11_000.0, 0.36480),
            (15_000.0, 0.19476),
            (20_000.0, 0.08891),
            (25_000.0, 0.04008),
        ] {
            let h = geopotential(z);
            assert!((density(h) / rho - 1.0).abs() < 3e-4, "ρ({h}) = {} against {rho}", density(h));
        }
        assert!((speed_of_sound(0.0) - 340.29).abs() < 0.01);
        assert!((speed_of_sound(11_000.0) - 295.07).abs() < 0.01);
    }

    #[test]
    fn it_is_continuous_across_its_layers() {
        for h in [11_000.0, 20_000.0] {
            let (below, above) = (density(h - 1e-6), density(h + 1e-6));
            assert!((below / above - 1.0).abs() < 1e-6, "{h}: {below} vs {above}");
        }
    }
}
