//! The picture of a vibrated bed, shared by `vibrating_bed` and `distributed_bed`.

use simkit::backend::Result;
use simkit::dem::{Scene, State};
use simkit::output::RgbImage;
use simkit::output::particles::ParticleFrame;

/// Discs coloured by speed, the vibrating plates in grey; `zw` is the plate displacement.
/// Lengths in grain diameters d, time in 1/ω.
pub fn draw(scene: &Scene, s: &State, zw: f64, vmax: f64, gamma: f64) -> Result<RgbImage> {
    let (lo, hi) = (scene.lo(), scene.hi());
    let a = scene.vibration().map_or(0.0, |v| v.amplitude);
    let pos: Vec<[f64; 2]> = s.positions.iter().map(|x| [x[0], x[1]]).collect();
    let radii: Vec<f64> = scene.particles().iter().map(|p| p.radius).collect();
    let speed: Vec<f64> = s.velocities.iter().map(|v| v[0].hypot(v[1])).collect();
    ParticleFrame::new(&pos, &radii)
        .bounds(lo[0], hi[0], lo[1] - a, hi[1] + a)
        .by_value(&speed, "|v| (d ω)")
        .range(0.0, vmax)
        .line((lo[0], lo[1] + zw), (hi[0], lo[1] + zw))
        .line((lo[0], hi[1] + zw), (hi[0], hi[1] + zw))
        .title(format!("vibrated bed, Γ = {gamma}"))
        .subtitle(format!(
            "t = {:.2} / ω ({:.2} cycles)",
            s.time,
            s.time / (2.0 * std::f64::consts::PI)
        ))
        .x_label("x (grain diameters d)")
        .y_label("z (d)")
        .render()
}
