//! What a wiring verdict most likely means, in the words of the input's unit:
//! the supervisor's fit of an inconsistent input says how its value relates
//! to its prediction (a scale and a mean innovation), and a few values of
//! those are the mistakes an installation makes.

/// The likely cause of an input whose value reads `scale` times its
/// prediction with a mean innovation `offset` (in `unit`), as a clause.
pub fn likely_cause(scale: f64, offset: f64, unit: Option<&str>) -> String {
    let acceleration = unit == Some("m/s2");
    let unit = unit.unwrap_or("");
    let fit = format!("its value reads {scale:.2} times its prediction, {offset:+.3} {unit} off on average");
    let cause = if (scale + 1.0).abs() < 0.5 {
        "its sign looks flipped"
    } else if acceleration && scale > 4.0 {
        "it looks 9.81 times too large: in g where m/s2 are expected?"
    } else if acceleration && scale > 0.0 && scale < 0.25 {
        "it looks 9.81 times too small: in m/s2 where g is expected?"
    } else if acceleration && (offset.abs() - 9.81).abs() < 3.0 {
        "it looks like it carries gravity (about 9.81 m/s2 off)"
    } else {
        "a wrong gain or zero, or a channel swapped with another?"
    };
    format!("{cause} ({fit})")
}

#[cfg(test)]
mod tests {
    use super::likely_cause;

    #[test]
    fn each_installation_mistake_is_named() {
        let m = Some("m/s2");
        assert!(likely_cause(-0.8, 0.0, m).starts_with("its sign looks flipped"));
        assert!(likely_cause(8.5, 0.0, m).contains("in g where m/s2"));
        assert!(likely_cause(0.12, 0.0, m).contains("in m/s2 where g"));
        assert!(likely_cause(0.9, -9.5, m).contains("carries gravity"));
        assert!(likely_cause(0.4, 1.0, m).contains("swapped"));
        assert!(likely_cause(8.5, 0.0, Some("m")).contains("swapped"), "a unit factor is named for accelerations only");
    }
}
