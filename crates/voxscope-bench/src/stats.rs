//! The figures a report gives of many timings: nearest-rank percentiles and their summary.

use serde_json::json;

/// Nearest-rank percentile (`NaN` of no values).
pub fn percentile(values: &[f64], p: f64) -> f64 {
    if values.is_empty() {
        return f64::NAN;
    }
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    let rank = ((p / 100.0) * sorted.len() as f64).ceil().max(1.0) as usize;
    sorted[rank.min(sorted.len()) - 1]
}

/// The median, 99th percentile and maximum of `values`, as JSON.
pub(crate) fn summary(values: &[f64]) -> serde_json::Value {
    json!({
        "median": percentile(values, 50.0),
        "p99": percentile(values, 99.0),
        "max": values.iter().copied().fold(f64::NAN, f64::max),
    })
}

#[cfg(test)]
mod tests {
    use super::percentile;

    #[test]
    fn percentiles_are_nearest_rank() {
        let values = [5.0, 1.0, 3.0, 2.0, 4.0];
        assert_eq!(percentile(&values, 50.0), 3.0);
        assert_eq!(percentile(&values, 95.0), 5.0);
        assert_eq!(percentile(&values, 0.0), 1.0);
    }
}
