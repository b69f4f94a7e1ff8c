//! A recorded run as a filter takes it: the sample times, and at each one the measurement
//! vector (NaN where a row is missing) and the controls (the model's known inputs, held
//! from their sample to the next, as the FMU holds them).

/// The samples of one log, in time order.
#[derive(Debug, Clone, PartialEq)]
pub struct Record {
    time: Vec<f64>,
    measurement_dim: usize,
    control_dim: usize,
    /// `measurement_dim` values per sample.
    measurements: Vec<f64>,
    /// `control_dim` values per sample.
    controls: Vec<f64>,
}

impl Record {
    /// An empty record of `measurement_dim` measurement rows and `control_dim` controls.
    pub fn new(measurement_dim: usize, control_dim: usize) -> Self {
        Self { time: Vec::new(), measurement_dim, control_dim, measurements: Vec::new(), controls: Vec::new() }
    }

    /// Appends the sample at `time`: `z` its measurement (non-finite: missing), `u` its
    /// controls (a control is never missing: the filter cannot predict without it).
    pub fn push(&mut self, time: f64, z: &[f64], u: &[f64]) -> Result<(), String> {
        if z.len() != self.measurement_dim || u.len() != self.control_dim {
            return Err(format!(
                "a sample has {} measurement rows and {} controls, the record {} and {}",
                z.len(),
                u.len(),
                self.measurement_dim,
                self.control_dim
            ));
        }
        if !time.is_finite() || self.time.last().is_some_and(|&last| time <= last) {
            return Err(format!("sample times must be finite and increase, got {time} s after {:?}", self.time.last()));
        }
        if let Some(v) = u.iter().find(|v| !v.is_finite()) {
            return Err(format!("a control must be finite (it cannot be missing), got {v} at t = {time} s"));
        }
        self.time.push(time);
        self.measurements.extend_from_slice(z);
        self.controls.extend_from_slice(u);
        Ok(())
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.time.len()
    }

    /// Whether it has no sample.
    pub fn is_empty(&self) -> bool {
        self.time.is_empty()
    }

    /// Measurement rows per sample.
    pub fn measurement_dim(&self) -> usize {
        self.measurement_dim
    }

    /// Controls per sample.
    pub fn control_dim(&self) -> usize {
        self.control_dim
    }

    /// The sample times (s).
    pub fn times(&self) -> &[f64] {
        &self.time
    }

    /// The measurement of sample `k`.
    pub fn measurement(&self, k: usize) -> &[f64] {
        &self.measurements[k * self.measurement_dim..(k + 1) * self.measurement_dim]
    }

    /// The controls of sample `k`.
    pub fn control(&self, k: usize) -> &[f64] {
        &self.controls[k * self.control_dim..(k + 1) * self.control_dim]
    }

    /// The instant of the filter's grid `t₀ + k·sample_time` that sample `k` lies on (the
    /// nearest; [`Record::check_grid`] checks that it lies on it).
    pub fn grid_index(&self, k: usize, sample_time: f64) -> u64 {
        ((self.time[k] - self.time[0]) / sample_time).round() as u64
    }

    /// The time from the first sample to the last (s).
    pub fn duration(&self) -> f64 {
        match (self.time.first(), self.time.last()) {
            (Some(first), Some(last)) => last - first,
            _ => 0.0,
        }
    }

    /// The measurement rows that are present (finite), over all samples.
    pub fn present_rows(&self) -> usize {
        self.measurements.iter().filter(|v| v.is_finite()).count()
    }

    /// The samples of the first `seconds` seconds: those with `t − t₀ < seconds`.
    pub fn leading(&self, seconds: f64) -> Record {
        let Some(&first) = self.time.first() else { return self.clone() };
        let count = self.time.iter().take_while(|&&t| t - first < seconds).count();
        Record {
            time: self.time[..count].to_vec(),
            measurement_dim: self.measurement_dim,
            control_dim: self.control_dim,
            measurements: self.measurements[..count * self.measurement_dim].to_vec(),
            controls: self.controls[..count * self.control_dim].to_vec(),
        }
    }

    /// Checks that every sample lies on the filter's grid `t₀ + k·sample_time` (to a
    /// millionth of a sample, the FMU's tolerance): a sample off the grid is no
    /// measurement for the FMU, so the log was not made at this sample time.
    pub fn check_grid(&self, sample_time: f64) -> Result<(), String> {
        let Some(&first) = self.time.first() else { return Ok(()) };
        for &t in &self.time {
            let k = ((t - first) / sample_time).round();
            if (t - first - k * sample_time).abs() > 1e-6 * sample_time {
                return Err(format!(
                    "the sample at t = {t} s is not on the grid {first} s + k·{sample_time} s: the log was made at \
                     another sample time (set it with --set sample_time=...)"
                ));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_record_keeps_its_samples_and_refuses_what_the_fmu_would() {
        let mut r = Record::new(2, 1);
        r.push(0.0, &[1.0, f64::NAN], &[0.5]).unwrap();
        r.push(0.1, &[2.0, 3.0], &[0.5]).unwrap();
        r.push(0.3, &[4.0, 5.0], &[0.0]).unwrap();
        assert_eq!(r.len(), 3);
        assert_eq!(r.measurement(1), &[2.0, 3.0]);
        assert_eq!(r.control(2), &[0.0]);
        assert_eq!(r.present_rows(), 5);
        assert!(r.push(0.3, &[1.0, 1.0], &[0.0]).is_err(), "time must increase");
        assert!(r.push(0.4, &[1.0], &[0.0]).is_err(), "row count");
        assert!(r.push(0.4, &[1.0, 1.0], &[f64::NAN]).is_err(), "a control is never missing");
        assert_eq!(r.leading(0.2).len(), 2);
        assert!(r.check_grid(0.1).is_ok(), "a gap of two samples is on the grid");
        assert!(r.check_grid(0.2).unwrap_err().contains("t = 0.1 s"));
    }
}
