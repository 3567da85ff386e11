//! Light selection: picks one light per next-event estimate with probability proportional to
//! its emitted power (Walker/Vose alias table, O(1) per sample).

use super::Light;

/// Lights whose power is positive get at least this fraction of the mean positive power, so a
/// dim light that matters locally (a lamp beside the camera under a bright sun) is still chosen.
const POWER_FLOOR: f64 = 0.01;

#[derive(Clone, Debug, Default)]
pub struct LightSampler {
    /// Probability that slot i keeps its own index (else it yields `alias[i]`).
    prob: Vec<f32>,
    alias: Vec<u32>,
    pmf: Vec<f32>,
}

impl LightSampler {
    /// Builds the table from `Light::power()`. Lights of zero (or non-finite) power are never
    /// chosen; if every light has zero power, `sample` returns None.
    pub fn new(lights: &[Light]) -> Self {
        let powers: Vec<f32> = lights.iter().map(|l| l.power()).collect();
        Self::from_powers(&powers)
    }

    /// Builds the table from explicit weights (the same rules as `new`).
    pub fn from_powers(powers: &[f32]) -> Self {
        let n = powers.len();
        let clean: Vec<f64> = powers.iter().map(|&p| if p.is_finite() && p > 0.0 { p as f64 } else { 0.0 }).collect();
        let n_pos = clean.iter().filter(|&&p| p > 0.0).count();
        if n_pos == 0 {
            return LightSampler { prob: vec![0.0; n], alias: (0..n as u32).collect(), pmf: vec![0.0; n] };
        }
        let mean = clean.iter().sum::<f64>() / n_pos as f64;
        let w: Vec<f64> = clean.iter().map(|&p| if p > 0.0 { p.max(POWER_FLOOR * mean) } else { 0.0 }).collect();
        let total: f64 = w.iter().sum();
        let pmf: Vec<f32> = w.iter().map(|&x| (x / total) as f32).collect();

        // Vose's alias method on scaled probabilities n·p_i
        let mut scaled: Vec<f64> = w.iter().map(|&x| x / total * n as f64).collect();
        let mut prob = vec![0.0f32; n];
        let mut alias: Vec<u32> = (0..n as u32).collect();
        let mut small: Vec<usize> = Vec::new();
        let mut large: Vec<usize> = Vec::new();
        for (i, &s) in scaled.iter().enumerate() {
            if s < 1.0 {
                small.push(i)
            } else {
                large.push(i)
            }
        }
        while let (Some(&s), Some(&l)) = (small.last(), large.last()) {
            small.pop();
            prob[s] = scaled[s] as f32;
            alias[s] = l as u32;
            scaled[l] -= 1.0 - scaled[s];
            if scaled[l] < 1.0 {
                large.pop();
                small.push(l);
            }
        }
        // leftovers are 1 up to rounding
        for i in large.into_iter().chain(small) {
            prob[i] = 1.0;
            alias[i] = i as u32;
        }
        LightSampler { prob, alias, pmf }
    }

    pub fn len(&self) -> usize {
        self.pmf.len()
    }

    pub fn is_empty(&self) -> bool {
        self.pmf.is_empty()
    }

    /// Picks a light for `u` in [0,1): (index, probability of that index).
    #[inline]
    pub fn sample(&self, u: f32) -> Option<(usize, f32)> {
        let n = self.pmf.len();
        if n == 0 {
            return None;
        }
        let x = u * n as f32;
        let i = (x as usize).min(n - 1);
        let frac = x - i as f32;
        let j = if frac < self.prob[i] { i } else { self.alias[i] as usize };
        let p = self.pmf[j];
        if p > 0.0 {
            Some((j, p))
        } else {
            None
        }
    }

    /// Probability that `sample` picks `index` (0 out of range).
    #[inline]
    pub fn pmf(&self, index: usize) -> f32 {
        self.pmf.get(index).copied().unwrap_or(0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::chi2::{gamma_q, TestRng};

    #[test]
    fn frequencies_match_the_pmf() {
        let powers = [5.0, 0.0, 1.0, 100.0, 0.0001, 20.0, 3.0];
        let s = LightSampler::from_powers(&powers);
        let total: f32 = (0..powers.len()).map(|i| s.pmf(i)).sum();
        assert!((total - 1.0).abs() < 1e-5);
        assert_eq!(s.pmf(1), 0.0);
        // the floor lifts the tiny light to 1 % of the mean positive power
        assert!(s.pmf(4) > 0.001, "{}", s.pmf(4));
        assert!((s.pmf(3) / s.pmf(0) - 20.0).abs() < 1e-3);
        let n = 200_000;
        let mut counts = vec![0f64; powers.len()];
        let mut rng = TestRng::new(11);
        for _ in 0..n {
            let (i, p) = s.sample(rng.next_f32()).unwrap();
            assert_eq!(p, s.pmf(i));
            counts[i] += 1.0;
        }
        let mut stat = 0.0;
        let mut dof = 0;
        for i in 0..powers.len() {
            let e = n as f64 * s.pmf(i) as f64;
            if e == 0.0 {
                assert_eq!(counts[i], 0.0);
                continue;
            }
            stat += (counts[i] - e).powi(2) / e;
            dof += 1;
        }
        // significance 1e-3 for one seeded test; a wrong alias table shifts whole slots and fails by far
        assert!(gamma_q((dof - 1) as f64 / 2.0, stat / 2.0) > 1e-3, "χ² = {stat}, counts {counts:?}");
    }

    #[test]
    fn no_power_means_no_light() {
        let s = LightSampler::from_powers(&[0.0, 0.0]);
        assert!(s.sample(0.3).is_none());
        assert!(LightSampler::from_powers(&[]).sample(0.5).is_none());
        let one = LightSampler::from_powers(&[0.0, 2.0]);
        for k in 0..10 {
            assert_eq!(one.sample(k as f32 / 10.0), Some((1, 1.0)));
        }
    }
}
