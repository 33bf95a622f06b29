//! Macroscopic fields: per-site density and momentum, block averages over `b x b` sites
//! (the noise falls as 1/b) and time averages. The fields are returned as data; writing
//! them to images or VTK files is left to the caller (e.g. `simkit-output`).

use simkit_backend::{Error, Result};

use crate::field::BlockField;

/// Accumulates block fields over time (sums of particles and momenta, so the averaged
/// velocity is total momentum over total particles).
#[derive(Clone, Debug, Default)]
pub struct TimeAverage {
    sum: Option<BlockField>,
}

impl TimeAverage {
    /// An empty average.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds one block field; errors when its block grid differs from earlier ones.
    pub fn add(&mut self, field: &BlockField) -> Result<()> {
        match &mut self.sum {
            None => self.sum = Some(field.clone()),
            Some(s) => {
                if (s.nx, s.ny, s.block) != (field.nx, field.ny, field.block) {
                    return Err(Error::invalid(
                        "block field",
                        format!("{} x {} blocks of {}", field.nx, field.ny, field.block),
                        format!(
                            "must match the average's {} x {} blocks of {}",
                            s.nx, s.ny, s.block
                        ),
                    ));
                }
                for (a, b) in [
                    (&mut s.sites, &field.sites),
                    (&mut s.particles, &field.particles),
                    (&mut s.px, &field.px),
                    (&mut s.py, &field.py),
                ] {
                    a.iter_mut().zip(b).for_each(|(x, y)| *x += y);
                }
                s.samples += field.samples;
            }
        }
        Ok(())
    }

    /// Samples added so far.
    pub fn samples(&self) -> u64 {
        self.sum.as_ref().map_or(0, |s| s.samples)
    }

    /// The accumulated field (`None` before the first sample).
    pub fn field(&self) -> Option<&BlockField> {
        self.sum.as_ref()
    }

    /// Clears the average.
    pub fn reset(&mut self) {
        self.sum = None;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Lattice;

    #[test]
    fn block_noise_falls_with_block_size() {
        let mut l = Lattice::new(256, 256).unwrap();
        l.fill_random(0.3, 2).unwrap();
        let rms = |b: usize| {
            let f = BlockField::from_lattice(&l, b).unwrap();
            let (ux, _) = f.velocity();
            (ux.iter().map(|u| u * u).sum::<f64>() / ux.len() as f64).sqrt()
        };
        let (r4, r16) = (rms(4), rms(16));
        // Noise ~ 1/b: a factor 4 in b gives about 4 in rms.
        assert!((r4 / r16 - 4.0).abs() < 0.6, "{r4} {r16}");
        let f = BlockField::from_lattice(&l, 8).unwrap();
        let d: f64 = f.density().iter().sum::<f64>() / (f.nx * f.ny) as f64;
        assert!((d / 6.0 - 0.3).abs() < 0.01);
        let mut avg = TimeAverage::new();
        avg.add(&f).unwrap();
        avg.add(&f).unwrap();
        assert_eq!(avg.samples(), 2);
        assert_eq!(avg.field().unwrap().velocity(), f.velocity());
        assert!(avg.add(&BlockField::from_lattice(&l, 4).unwrap()).is_err());
        assert!(BlockField::from_lattice(&l, 0).is_err());
    }
}
