//! Leaf count variability (Aila, Karras and Laine 2013).

/// Leaf count variability: the standard deviation of the number of leaves each ray visited.
///
/// This is the **population** standard deviation, `sqrt(Σ (x - mean)² / N)`: the ray set is
/// the whole population being measured, not a sample of a larger one (for the 10⁴–10⁶ rays of
/// a measurement the difference from the sample deviation, which divides by `N - 1`, is below
/// 10⁻⁴ relative). Computed in two passes in `f64`. Returns 0 for fewer than two rays.
///
/// ```
/// // Two rays visiting 1 and 3 leaves: mean 2, deviation 1.
/// assert_eq!(sahara_metrics::lcv(&[1, 3]), 1.0);
/// ```
pub fn lcv(leaves_visited_per_ray: &[u32]) -> f64 {
    let n = leaves_visited_per_ray.len();
    if n < 2 {
        return 0.0;
    }
    let mean = leaves_visited_per_ray
        .iter()
        .map(|&x| x as f64)
        .sum::<f64>()
        / n as f64;
    let var = leaves_visited_per_ray
        .iter()
        .map(|&x| {
            let d = x as f64 - mean;
            d * d
        })
        .sum::<f64>()
        / n as f64;
    var.sqrt()
}
