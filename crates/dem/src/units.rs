//! The source's normalised units for vibrated beds, from physical inputs.

use simkit_backend::Result;

/// Normalisation of a vibrated granular bed: length unit `d0` (a grain diameter), time unit
/// `1 / omega` (`omega = 2 pi f`), mass unit `m0`. In these units the vibration has
/// angular frequency 1, gravity is `g' = g / (d0 omega^2)` and the amplitude is
/// `A' = Gamma g'` (`Gamma = A omega^2 / g`).
///
/// Physical inputs are in cm, g, s and Hz (CGS), as in the source.
///
/// ```
/// use simkit_dem::Units;
/// # fn main() -> simkit_backend::Result<()> {
/// let u = Units::new(0.6, 0.2, 20.0)?; // d0 = 0.6 cm, m0 = 0.2 g, f = 20 Hz
/// assert!((u.gravity() - 980.0 / (0.6 * (2.0 * std::f64::consts::PI * 20.0f64).powi(2))).abs() < 1e-12);
/// assert!((u.amplitude(3.0) - 3.0 * u.gravity()).abs() < 1e-12);
/// # Ok(())
/// # }
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Units {
    /// Length unit in cm.
    pub d0_cm: f64,
    /// Mass unit in g.
    pub m0_g: f64,
    /// Vibration frequency in Hz.
    pub freq_hz: f64,
    /// Gravitational acceleration in cm/s^2 (980 by default).
    pub g_cm_s2: f64,
}

impl Units {
    /// Units for grains of diameter `d0_cm` and mass `m0_g` shaken at `freq_hz`
    /// (g = 980 cm/s^2).
    pub fn new(d0_cm: f64, m0_g: f64, freq_hz: f64) -> Result<Self> {
        simkit_backend::require_positive("d0 (cm)", d0_cm)?;
        simkit_backend::require_positive("m0 (g)", m0_g)?;
        simkit_backend::require_positive("frequency (Hz)", freq_hz)?;
        Ok(Self {
            d0_cm,
            m0_g,
            freq_hz,
            g_cm_s2: 980.0,
        })
    }

    /// Angular frequency `omega = 2 pi f` in 1/s.
    pub fn omega(&self) -> f64 {
        2.0 * std::f64::consts::PI * self.freq_hz
    }

    /// Time unit `1 / omega` in seconds.
    pub fn time_unit_s(&self) -> f64 {
        1.0 / self.omega()
    }

    /// Reduced gravity `g' = g / (d0 omega^2)`.
    pub fn gravity(&self) -> f64 {
        self.g_cm_s2 / (self.d0_cm * self.omega().powi(2))
    }

    /// Reduced amplitude `A' = Gamma g'` for vibration strength `Gamma = A omega^2 / g`.
    pub fn amplitude(&self, gamma: f64) -> f64 {
        gamma * self.gravity()
    }

    /// A duration in seconds (e.g. a contact time) in reduced units: `t omega`.
    pub fn time(&self, seconds: f64) -> f64 {
        seconds * self.omega()
    }

    /// A length in cm in reduced units.
    pub fn length(&self, cm: f64) -> f64 {
        cm / self.d0_cm
    }

    /// A mass in g in reduced units.
    pub fn mass(&self, grams: f64) -> f64 {
        grams / self.m0_g
    }

    /// A reduced length back in cm.
    pub fn length_cm(&self, reduced: f64) -> f64 {
        reduced * self.d0_cm
    }

    /// A reduced time back in seconds.
    pub fn time_s(&self, reduced: f64) -> f64 {
        reduced / self.omega()
    }

    /// A reduced velocity back in cm/s.
    pub fn velocity_cm_s(&self, reduced: f64) -> f64 {
        reduced * self.d0_cm * self.omega()
    }
}
