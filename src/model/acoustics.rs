//! The sea's acoustics as the field's link models use them: absorption
//! (Thorp, Francois-Garrison, Schulkin-Marsh) and ambient noise (constant, or Coates'
//! four components as Stojanovic 2007 gives them), integrated over the band.
//!
//! # Units
//! Every absorption here is in **dB/km** with the frequency in **kHz**.
//! The field's codes disagree on this: Thorp (1967) published
//! `0.1 f^2/(1+f^2) + 40 f^2/(4100+f^2) + 2.75e-4 f^2 + 0.003` in dB per
//! kiloyard; the `0.11` and `44` of the dB/km form are those coefficients
//! times 1.094 (km per kyd), and ns-3's UAN `GetAttenDbKyd` returns the dB/km
//! coefficients under a dB/kyd name, with the two frequency branches
//! swapped. Schulkin and Marsh's formula comes in two forms too: with
//! `A = 2.34e-6`, `B = 3.38e-6` and the factor `8.686e3` (nepers per metre
//! to dB/km) it is in dB/km, the form used here; Urick's `A = 1.86e-2`,
//! `B = 2.68e-2` are the same coefficients in dB per kiloyard (times
//! 1.094 they give `8.686e3 A` and `8.686e3 B`). Noise levels are spectral
//! densities in dB re 1 uPa^2/Hz.

use crate::model::error::{KeyError, in_range};
use serde::{Deserialize, Serialize};

/// Thorp's absorption in dB/km, `f` in kHz, both branches (Stojanovic 2007
/// eq. 3 and the low-frequency form of the UASN simulators): for
/// `f >= 0.4`, `0.11 f^2/(1+f^2) + 44 f^2/(4100+f^2) + 2.75e-4 f^2 +
/// 0.003`; below, `0.002 + 0.11 f/(1+f) + 0.011 f`.
pub fn thorp_db_per_km(f_khz: f64) -> f64 {
    if f_khz >= 0.4 {
        let f2 = f_khz * f_khz;
        0.11 * f2 / (1.0 + f2) + 44.0 * f2 / (4100.0 + f2) + 2.75e-4 * f2 + 0.003
    } else {
        0.002 + 0.11 * f_khz / (1.0 + f_khz) + 0.011 * f_khz
    }
}

/// The water a path crosses, for [`Absorption::FrancoisGarrison`] and
/// [`Absorption::MarshSchulkin`] (which does not take the pH).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Water {
    /// Temperature, degrees C, in [-2, 40] (default 4).
    #[serde(default = "default_temperature")]
    pub temperature_c: f64,
    /// Salinity, psu (parts per thousand), in [0, 45] (default 35).
    #[serde(default = "default_salinity")]
    pub salinity_psu: f64,
    /// Acidity, in [6, 9] (default 8).
    #[serde(default = "default_ph")]
    pub ph: f64,
    /// The depth of every path in a 2-D scenario, metres, in [0, 12000]
    /// (default 0); a 3-D path takes the mean depth of its two ends.
    #[serde(default)]
    pub depth_m: f64,
}

fn default_temperature() -> f64 {
    4.0
}
fn default_salinity() -> f64 {
    35.0
}
fn default_ph() -> f64 {
    8.0
}

impl Default for Water {
    fn default() -> Self {
        Water {
            temperature_c: default_temperature(),
            salinity_psu: default_salinity(),
            ph: default_ph(),
            depth_m: 0.0,
        }
    }
}

impl Water {
    /// The ranges of the module docs; the [`KeyError`] names the key under
    /// `prefix`.
    pub fn validate(&self, prefix: &str) -> Result<(), KeyError> {
        in_range(
            &format!("{prefix}.temperature_c"),
            self.temperature_c,
            -2.0,
            40.0,
        )?;
        in_range(
            &format!("{prefix}.salinity_psu"),
            self.salinity_psu,
            0.0,
            45.0,
        )?;
        in_range(&format!("{prefix}.ph"), self.ph, 6.0, 9.0)?;
        in_range(&format!("{prefix}.depth_m"), self.depth_m, 0.0, 12_000.0)
    }
}

/// Francois and Garrison (1982, J. Acoust. Soc. Am. 72(6), "Sound absorption
/// based on ocean measurements. Part II") in dB/km, `f` in kHz, at depth
/// `z_m` metres: boric acid, magnesium sulphate and pure water,
/// `A1 P1 f1 f^2/(f1^2+f^2) + A2 P2 f2 f^2/(f2^2+f^2) + A3 P3 f^2`, with the
/// sound speed `c = 1412 + 3.21 T + 1.19 S + 0.0167 z`.
pub fn francois_garrison_db_per_km(f_khz: f64, w: &Water, z_m: f64) -> f64 {
    let (t, s, z) = (w.temperature_c, w.salinity_psu, z_m);
    let f2 = f_khz * f_khz;
    let kelvin = t + 273.0;
    let c = 1412.0 + 3.21 * t + 1.19 * s + 0.0167 * z;
    // Boric acid.
    let a1 = 8.86 / c * 10f64.powf(0.78 * w.ph - 5.0);
    let f1 = 2.8 * (s / 35.0).sqrt() * 10f64.powf(4.0 - 1245.0 / kelvin);
    // Magnesium sulphate.
    let a2 = 21.44 * s / c * (1.0 + 0.025 * t);
    let p2 = 1.0 - 1.37e-4 * z + 6.2e-9 * z * z;
    let f2r = 8.17 * 10f64.powf(8.0 - 1990.0 / kelvin) / (1.0 + 0.0018 * (s - 35.0));
    // Pure water.
    let a3 = if t <= 20.0 {
        4.937e-4 - 2.59e-5 * t + 9.11e-7 * t * t - 1.50e-8 * t * t * t
    } else {
        3.964e-4 - 1.146e-5 * t + 1.45e-7 * t * t - 6.5e-10 * t * t * t
    };
    let p3 = 1.0 - 3.83e-5 * z + 4.9e-10 * z * z;
    a1 * f1 * f2 / (f1 * f1 + f2) + a2 * p2 * f2r * f2 / (f2r * f2r + f2) + a3 * p3 * f2
}

/// The absolute pressure at depth `z_m` metres, kg/cm^2: one standard
/// atmosphere plus a column of sea water of density 1025 kg/m^3 under
/// standard gravity (about 1.033 + 0.1025 z).
pub fn pressure_kg_per_cm2(z_m: f64) -> f64 {
    (101_325.0 + 1025.0 * 9.806_65 * z_m) / 98_066.5
}

/// Schulkin and Marsh (1962, J. Acoust. Soc. Am. 34(6), "Sound absorption
/// in sea water") in dB/km, `f` in kHz, at depth `z_m` metres: magnesium
/// sulphate relaxation and pure water,
/// `8.686e3 (S A fT f^2/(fT^2+f^2) + B f^2/fT) (1 - 6.54e-4 P)` with
/// `A = 2.34e-6`, `B = 3.38e-6`, the relaxation frequency
/// `fT = 21.9 10^(6 - 1520/(T+273))` kHz and the pressure `P` in kg/cm^2
/// ([`pressure_kg_per_cm2`]). Fitted to measurements from 2 to 25 kHz; it
/// has no boric acid term, so below about 5 kHz it absorbs far less than
/// [`francois_garrison_db_per_km`] (a fifth to a third at 1-2 kHz).
pub fn schulkin_marsh_db_per_km(f_khz: f64, w: &Water, z_m: f64) -> f64 {
    const A: f64 = 2.34e-6;
    const B: f64 = 3.38e-6;
    let f2 = f_khz * f_khz;
    let ft = 21.9 * 10f64.powf(6.0 - 1520.0 / (w.temperature_c + 273.0));
    let relaxation = w.salinity_psu * A * ft * f2 / (ft * ft + f2);
    let viscous = B * f2 / ft;
    8.686e3 * (relaxation + viscous) * (1.0 - 6.54e-4 * pressure_kg_per_cm2(z_m))
}

/// Which absorption a link's transmission loss takes
/// (`channel.loss.absorption`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Absorption {
    /// [`thorp_db_per_km`] (frequency only).
    #[default]
    Thorp,
    /// [`francois_garrison_db_per_km`] in the link's [`Water`].
    FrancoisGarrison,
    /// [`schulkin_marsh_db_per_km`] in the link's [`Water`]
    /// (`"marsh_schulkin"`, the name ns-3 and the UASN simulators use).
    MarshSchulkin,
}

impl Absorption {
    /// dB/km at `f_khz` in water `w` at depth `z_m`.
    pub fn db_per_km(self, f_khz: f64, w: &Water, z_m: f64) -> f64 {
        match self {
            Absorption::Thorp => thorp_db_per_km(f_khz),
            Absorption::FrancoisGarrison => francois_garrison_db_per_km(f_khz, w, z_m),
            Absorption::MarshSchulkin => schulkin_marsh_db_per_km(f_khz, w, z_m),
        }
    }
}

/// The ambient noise (`channel.loss.noise`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "model", rename_all = "snake_case", deny_unknown_fields)]
pub enum Noise {
    /// A flat spectral density, dB re 1 uPa^2/Hz, in [-100, 200].
    Constant {
        /// The level.
        level_db: f64,
    },
    /// Coates (1989) as Stojanovic 2007 eq. (7) gives it, `f` in kHz:
    /// turbulence `17 - 30 log f`, shipping `40 + 20 (s - 0.5) + 26 log f -
    /// 60 log(f + 0.03)`, wind `50 + 7.5 w^(1/2) + 20 log f - 40 log(f +
    /// 0.4)` and thermal `-15 + 20 log f` dB re 1 uPa^2/Hz, summed in power.
    Coates {
        /// Shipping activity `s`, in [0, 1] (default 0.5).
        #[serde(default = "default_shipping")]
        shipping: f64,
        /// Wind speed `w`, m/s, in [0, 50] (default 0).
        #[serde(default)]
        wind_mps: f64,
    },
}

fn default_shipping() -> f64 {
    0.5
}

/// The four components of [`Noise::Coates`] at `f_khz`, dB re 1 uPa^2/Hz:
/// `[turbulence, shipping, wind, thermal]`.
pub fn coates_components_db(f_khz: f64, shipping: f64, wind_mps: f64) -> [f64; 4] {
    let lf = f_khz.log10();
    [
        17.0 - 30.0 * lf,
        40.0 + 20.0 * (shipping - 0.5) + 26.0 * lf - 60.0 * (f_khz + 0.03).log10(),
        50.0 + 7.5 * wind_mps.sqrt() + 20.0 * lf - 40.0 * (f_khz + 0.4).log10(),
        -15.0 + 20.0 * lf,
    ]
}

/// Points of the composite Simpson rule over the band (even).
const BAND_STEPS: usize = 64;

impl Noise {
    /// The spectral density at `f_khz`, dB re 1 uPa^2/Hz.
    pub fn density_db(&self, f_khz: f64) -> f64 {
        match *self {
            Noise::Constant { level_db } => level_db,
            Noise::Coates { shipping, wind_mps } => {
                let p: f64 = coates_components_db(f_khz, shipping, wind_mps)
                    .iter()
                    .map(|db| 10f64.powf(db / 10.0))
                    .sum();
                10.0 * p.log10()
            }
        }
    }

    /// The noise power in the band `[fc - B/2, fc + B/2]` (kHz), dB re
    /// 1 uPa^2: `level + 10 log10(B)` for a constant level, the density
    /// integrated over the band (composite Simpson, 64 intervals) for Coates.
    pub fn band_db(&self, carrier_khz: f64, bandwidth_khz: f64) -> f64 {
        let b_hz = bandwidth_khz * 1e3;
        match *self {
            Noise::Constant { level_db } => level_db + 10.0 * b_hz.log10(),
            Noise::Coates { .. } => {
                let lo = (carrier_khz - bandwidth_khz / 2.0).max(carrier_khz * 1e-3);
                let hi = carrier_khz + bandwidth_khz / 2.0;
                let h = (hi - lo) / BAND_STEPS as f64;
                let density = |f: f64| 10f64.powf(self.density_db(f) / 10.0);
                let inner: f64 = (1..BAND_STEPS)
                    .map(|k| {
                        let w = if k % 2 == 1 { 4.0 } else { 2.0 };
                        w * density(lo + k as f64 * h)
                    })
                    .sum();
                // Simpson over kHz, times 1000 Hz per kHz.
                let power = (density(lo) + inner + density(hi)) * h / 3.0 * 1e3;
                10.0 * power.log10()
            }
        }
    }

    /// The ranges of the module docs under `key`.
    pub fn validate(&self, key: &str) -> Result<(), KeyError> {
        match *self {
            Noise::Constant { level_db } => {
                in_range(&format!("{key}.level_db"), level_db, -100.0, 200.0)
            }
            Noise::Coates { shipping, wind_mps } => {
                in_range(&format!("{key}.shipping"), shipping, 0.0, 1.0)?;
                in_range(&format!("{key}.wind_mps"), wind_mps, 0.0, 50.0)
            }
        }
    }
}

#[cfg(test)]
#[path = "acoustics_tests.rs"]
mod tests;
