//! Piecewise-constant distributions for importance sampling: 1D over weighted items or cells,
//! 2D over image pixels (a marginal over rows, a conditional per row).

/// A distribution proportional to non-negative weights, sampled by inverting its cdf.
///
/// The inversion starts from a guide table (Chen and Asau's index table): for u in the j-th of
/// M equal bins of [0, 1) the item lies between the items of the bin's two ends, so the search
/// is over those few entries, not all n (one or two for weights of similar size, as a
/// light's triangles mostly are). The item drawn is the bisection's, exactly.
#[derive(Clone, Debug, Default)]
pub struct Distribution1D {
    /// Normalised weights.
    pub(crate) probabilities: Vec<f32>,
    /// cdf[i] = Σ_{j<i} probabilities[j]; cdf[0] = 0 and cdf[n] = 1 exactly.
    pub(crate) cdf: Vec<f32>,
    /// guide[j] = the item drawn for u = j/M (M = guide.len() − 1, a power of two so that
    /// u·M is exact), guide[M] = n − 1; empty when there is nothing to sample.
    guide: Vec<u32>,
    /// Σ weights (before normalisation).
    total: f64,
}

/// The most bins a guide table has (a power of two, below 2²⁴ so that bin/M is an exact f32).
const MAX_GUIDE_BINS: usize = 1 << 20;

impl Distribution1D {
    /// Negative and non-finite weights count as zero. All-zero weights give an empty
    /// distribution (see [`Distribution1D::is_empty`]).
    pub fn new(weights: impl IntoIterator<Item = f32>) -> Self {
        let weights: Vec<f64> = weights
            .into_iter()
            .map(|w| {
                if w.is_finite() && w > 0.0 {
                    w as f64
                } else {
                    0.0
                }
            })
            .collect();
        let total: f64 = weights.iter().sum();
        if !(total > 0.0 && total.is_finite()) {
            return Distribution1D {
                probabilities: vec![0.0; weights.len()],
                cdf: vec![0.0; weights.len() + 1],
                guide: Vec::new(),
                total: 0.0,
            };
        }
        let mut cdf = Vec::with_capacity(weights.len() + 1);
        let mut running = 0.0f64;
        cdf.push(0.0);
        for w in &weights {
            running += w;
            cdf.push((running / total) as f32);
        }
        // Guard against rounding: the last entry must be exactly 1.
        if let Some(last) = cdf.last_mut() {
            *last = 1.0;
        }
        let guide = guide_table(&cdf);
        Distribution1D {
            probabilities: weights.iter().map(|w| (w / total) as f32).collect(),
            cdf,
            guide,
            total,
        }
    }

    /// True when there is nothing to sample (no items or all weights zero).
    pub fn is_empty(&self) -> bool {
        self.total <= 0.0
    }

    pub fn len(&self) -> usize {
        self.probabilities.len()
    }

    /// Σ weights.
    pub fn total(&self) -> f64 {
        self.total
    }

    /// Probability of drawing item `index` (zero out of range).
    pub fn probability(&self, index: usize) -> f32 {
        self.probabilities.get(index).copied().unwrap_or(0.0)
    }

    /// Draws an item for u ∈ [0, 1): its index and the position of u within its cdf interval,
    /// in [0, 1) (reusable as a fresh uniform number). Never returns a zero-probability item.
    pub fn sample(&self, u: f32) -> Option<(usize, f32)> {
        if self.is_empty() {
            return None;
        }
        let index = if (0.0..1.0).contains(&u) {
            // u·M is exact, so u lies in [bin/M, (bin + 1)/M): its item is at least the
            // bin's start's and at most its end's, and the last of those whose cdf ≤ u.
            let bins = self.guide.len() - 1;
            let bin = (u * bins as f32) as usize;
            let (first, last) = (self.guide[bin] as usize, self.guide[bin + 1] as usize);
            first + self.cdf[first + 1..=last].partition_point(|&c| c <= u)
        } else {
            self.bisect(u)
        };
        let (low, high) = (self.cdf[index], self.cdf[index + 1]);
        let within = if high > low {
            ((u - low) / (high - low)).clamp(0.0, 1.0 - f32::EPSILON / 2.0)
        } else {
            0.0
        };
        Some((index, within))
    }

    /// The item for `u` by bisection of the whole cdf: the last whose cdf entry is ≤ u (so
    /// never a zero-probability item), clamped to the items. What the guide table finds.
    fn bisect(&self, u: f32) -> usize {
        let n = self.probabilities.len();
        self.cdf
            .partition_point(|&c| c <= u)
            .saturating_sub(1)
            .min(n - 1)
    }

    /// Draws a point x ∈ [0, 1) of the piecewise-constant density over n equal cells:
    /// returns x, its density (w.r.t. x) and the cell.
    pub fn sample_continuous(&self, u: f32) -> Option<(f32, f32, usize)> {
        let (index, within) = self.sample(u)?;
        let n = self.len() as f32;
        Some((
            (index as f32 + within) / n,
            self.probabilities[index] * n,
            index,
        ))
    }

    /// Density of [`Distribution1D::sample_continuous`] at x ∈ [0, 1].
    pub fn density_continuous(&self, x: f32) -> f32 {
        let n = self.len();
        if n == 0 {
            return 0.0;
        }
        let cell = ((x * n as f32) as usize).min(n - 1);
        self.probabilities[cell] * n as f32
    }
}

/// The guide table of a distribution's `cdf` (n + 1 entries, 0 to 1): for each of M bins
/// (the power of two at or above n, at most [`MAX_GUIDE_BINS`]) the item drawn at the bin's
/// start, the last i < n with cdf[i] ≤ j/M; then n − 1 for u → 1. One walk along the cdf.
fn guide_table(cdf: &[f32]) -> Vec<u32> {
    let n = cdf.len() - 1;
    let bins = n.next_power_of_two().min(MAX_GUIDE_BINS);
    let mut guide = Vec::with_capacity(bins + 1);
    let mut item = 0;
    for bin in 0..bins {
        let start = bin as f32 / bins as f32;
        while item + 1 < n && cdf[item + 1] <= start {
            item += 1;
        }
        guide.push(item as u32);
    }
    guide.push((n - 1) as u32);
    guide
}

/// A piecewise-constant density over the unit square, given as a grid of cell weights
/// (row-major, `height` rows of `width` cells, row 0 at v = 0).
#[derive(Clone, Debug, Default)]
pub struct Distribution2D {
    pub(crate) rows: Vec<Distribution1D>,
    pub(crate) marginal: Distribution1D,
}

impl Distribution2D {
    pub fn new(weights: &[f32], width: usize, height: usize) -> Self {
        let rows: Vec<Distribution1D> = (0..height)
            .map(|y| Distribution1D::new(weights[y * width..(y + 1) * width].iter().copied()))
            .collect();
        let marginal = Distribution1D::new(rows.iter().map(|row| row.total() as f32));
        Distribution2D { rows, marginal }
    }

    pub fn is_empty(&self) -> bool {
        self.marginal.is_empty()
    }

    /// Draws (x, y) ∈ [0, 1)² with its density w.r.t. area in the unit square.
    pub fn sample(&self, u: [f32; 2]) -> Option<((f32, f32), f32)> {
        let (y, density_y, row) = self.marginal.sample_continuous(u[1])?;
        let (x, density_x, _) = self.rows[row].sample_continuous(u[0])?;
        Some(((x, y), density_x * density_y))
    }

    /// Density of [`Distribution2D::sample`] at (x, y).
    pub fn density(&self, x: f32, y: f32) -> f32 {
        let height = self.rows.len();
        if height == 0 || self.is_empty() {
            return 0.0;
        }
        let row = ((y * height as f32) as usize).min(height - 1);
        self.marginal.density_continuous(y) * self.rows[row].density_continuous(x)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    #[test]
    fn discrete_frequencies_follow_weights_and_skip_zeros() {
        let d = Distribution1D::new([1.0, 0.0, 3.0, f32::NAN, -2.0]);
        assert_eq!(d.probability(0), 0.25);
        assert_eq!(d.probability(2), 0.75);
        assert_eq!(d.probability(1), 0.0);
        assert_eq!(d.probability(3), 0.0);
        let mut rng = Rng::new(1, 1);
        let mut counts = [0usize; 5];
        for _ in 0..40_000 {
            let (i, within) = d.sample(rng.next_f32()).unwrap();
            assert!((0.0..1.0).contains(&within));
            counts[i] += 1;
        }
        assert_eq!(counts[1] + counts[3] + counts[4], 0);
        // σ of the count of item 0 is √(n p (1 − p)) ≈ 87: allow 5σ.
        assert!((counts[0] as f64 - 10_000.0).abs() < 450.0, "{counts:?}");
        // Edges of [0, 1).
        assert_eq!(d.sample(0.0).unwrap().0, 0);
        assert_eq!(d.sample(1.0 - f32::EPSILON).unwrap().0, 2);
    }

    /// The guide table finds the bisection's item for every u: at every bin's edges and
    /// between them, for even, skewed and heavy-tailed weights, runs of zeros at either end
    /// and inside, one item, and more items than bins.
    #[test]
    fn the_guide_table_draws_the_bisections_item() {
        let mut rng = Rng::new(7, 3);
        let skewed: Vec<f32> = (0..1000).map(|i| ((i % 97) as f32).powi(4)).collect();
        let tail: Vec<f32> = (0..300).map(|i| 1e-12 + (i == 150) as u32 as f32).collect();
        let zeros: Vec<f32> = [0.0; 5]
            .into_iter()
            .chain([2.0, 0.0, 0.0, 1.0, 0.5])
            .chain([0.0; 7])
            .collect();
        let even = vec![1.0f32; 128];
        let many: Vec<f32> = (0..(MAX_GUIDE_BINS + 4321))
            .map(|i| 1.0 + (i % 3) as f32)
            .collect();
        for weights in [skewed, tail, zeros, even, vec![3.0], many] {
            let d = Distribution1D::new(weights.iter().copied());
            let bins = d.guide.len() - 1;
            assert!(bins.is_power_of_two() && bins >= weights.len().min(MAX_GUIDE_BINS));
            let mut us: Vec<f32> = vec![0.0, f32::MIN_POSITIVE, 0.5, 1.0 - f32::EPSILON / 2.0];
            for bin in (0..bins).step_by((bins / 4096).max(1)) {
                let edge = bin as f32 / bins as f32;
                us.extend([edge, edge.next_up(), edge.next_down().max(0.0)]);
            }
            us.extend(d.cdf.iter().flat_map(|&c| [c, c.next_up(), c.next_down()]));
            us.extend((0..20_000).map(|_| rng.next_f32()));
            for u in us.into_iter().filter(|u| (0.0..1.0).contains(u)) {
                let (index, _) = d.sample(u).unwrap();
                assert_eq!(index, d.bisect(u), "u = {u} of {} items", weights.len());
                assert!(d.probability(index) > 0.0, "u = {u}");
            }
        }
    }

    #[test]
    fn empty_distributions_sample_nothing() {
        assert!(Distribution1D::new([]).sample(0.5).is_none());
        assert!(Distribution1D::new([0.0, 0.0]).sample(0.5).is_none());
        let d2 = Distribution2D::new(&[0.0; 4], 2, 2);
        assert!(d2.sample([0.3, 0.3]).is_none());
        assert_eq!(d2.density(0.3, 0.3), 0.0);
    }

    #[test]
    fn density_2d_integrates_to_one_and_matches_samples() {
        let weights = [1.0, 2.0, 0.0, 4.0, 0.5, 0.5];
        let d = Distribution2D::new(&weights, 3, 2);
        // Cells of area 1/6: Σ density × area = 1.
        let mut integral = 0.0;
        for y in 0..2 {
            for x in 0..3 {
                integral += d.density((x as f32 + 0.5) / 3.0, (y as f32 + 0.5) / 2.0) / 6.0;
            }
        }
        assert!((integral - 1.0).abs() < 1e-6);
        let mut rng = Rng::new(2, 2);
        for _ in 0..1000 {
            let ((x, y), pdf) = d.sample([rng.next_f32(), rng.next_f32()]).unwrap();
            assert!((pdf - d.density(x, y)).abs() < 1e-5 * pdf);
            assert!(pdf > 0.0);
        }
    }
}
