//! Absorption and noise against values computed independently (in Python,
//! from the formulas as MB-System's `mbabsorption` documents Francois and
//! Garrison 1982, as Stojanovic 2007 eq. (3) and (7) give Thorp and Coates,
//! and as oce's `swSoundAbsorption` and Al-Aboosi 2018 give Schulkin and
//! Marsh 1962) and against each other.

use super::*;
use approx::assert_relative_eq;

#[test]
fn thorp_takes_its_high_frequency_form_from_0_4_khz_and_its_low_form_below() {
    assert_relative_eq!(
        thorp_db_per_km(1.0),
        0.069_004_090_465_740_06,
        max_relative = 1e-14
    );
    assert_relative_eq!(
        thorp_db_per_km(10.0),
        1.187_029_938_708_156_7,
        max_relative = 1e-14
    );
    assert_relative_eq!(
        thorp_db_per_km(0.4),
        0.019_933_419_958_716_496,
        max_relative = 1e-14
    );
    assert_relative_eq!(
        thorp_db_per_km(0.2),
        0.022_533_333_333_333_336,
        max_relative = 1e-14
    );
}

#[test]
fn francois_garrison_matches_independent_values_in_db_per_km() {
    let w = |t: f64, s: f64, ph: f64| Water {
        temperature_c: t,
        salinity_psu: s,
        ph,
        depth_m: 0.0,
    };
    for (f, water, z, want) in [
        (1.0, w(4.0, 35.0, 8.0), 1000.0, 0.061_028_996_188_322_554),
        (10.0, w(4.0, 35.0, 8.0), 1000.0, 1.005_293_114_431_782_5),
        (12.0, w(10.0, 35.0, 8.0), 50.0, 1.318_798_071_070_292_5),
        // Above 20 C the pure-water term takes its second polynomial.
        (50.0, w(25.0, 34.0, 7.9), 300.0, 10.536_537_355_585_498),
        (0.2, w(4.0, 35.0, 8.0), 0.0, 0.004_899_426_217_544_706),
    ] {
        assert_relative_eq!(
            francois_garrison_db_per_km(f, &water, z),
            want,
            max_relative = 1e-12
        );
    }
}

#[test]
fn francois_garrison_stays_within_20_percent_of_thorp_where_thorp_was_fitted() {
    // Thorp's fit holds for about 4 C, 35 psu, pH 8 and 1000 m, 0.1-5 kHz;
    // Francois and Garrison absorb 12-16 % less there.
    let water = Water::default();
    for f in [1.0, 2.0, 5.0, 10.0] {
        let ratio = francois_garrison_db_per_km(f, &water, 1000.0) / thorp_db_per_km(f);
        assert!((0.8..1.0).contains(&ratio), "{f} kHz: {ratio}");
    }
}

#[test]
fn schulkin_marsh_matches_independent_values_in_db_per_km() {
    let w = |t: f64, s: f64| Water {
        temperature_c: t,
        salinity_psu: s,
        ph: 8.0,
        depth_m: 0.0,
    };
    for (f, water, z, want) in [
        (10.0, w(4.0, 35.0), 1000.0, 0.950_640_545_725_585_7),
        (12.0, w(10.0, 35.0), 50.0, 1.122_024_062_795_177_4),
        (50.0, w(25.0, 34.0), 300.0, 9.408_416_299_807_564),
        (2.0, w(4.0, 35.0), 0.0, 0.041_497_878_564_432_72),
        (25.0, w(15.0, 30.0), 5000.0, 2.198_442_401_880_079_4),
    ] {
        assert_relative_eq!(
            schulkin_marsh_db_per_km(f, &water, z),
            want,
            max_relative = 1e-12
        );
    }
}

#[test]
fn schulkin_marsh_at_its_relaxation_frequency_is_half_the_peak_plus_pure_water() {
    // fT = 21.9 10^(6 - 1520/277) = 71.298 kHz at 4 C; at f = fT the
    // relaxation term is S A fT / 2, the pure-water term B fT.
    let water = Water::default();
    let ft = 71.298_352_373_737_66;
    let p = (101_325.0 + 1025.0 * 9.806_65 * 200.0) / 98_066.5;
    let want = 8.686e3 * (35.0 * 2.34e-6 * ft / 2.0 + 3.38e-6 * ft) * (1.0 - 6.54e-4 * p);
    assert_relative_eq!(
        schulkin_marsh_db_per_km(ft, &water, 200.0),
        want,
        max_relative = 1e-12
    );
    // The pressure factor: 1 kg/cm^2 is 98,066.5 Pa; 10 m of sea water
    // adds 1.025 kg/cm^2 to the atmosphere's 1.033.
    assert_relative_eq!(pressure_kg_per_cm2(0.0), 1.033_227_45, max_relative = 1e-8);
    assert_relative_eq!(
        pressure_kg_per_cm2(10.0) - pressure_kg_per_cm2(0.0),
        1.025,
        max_relative = 1e-12
    );
}

#[test]
fn schulkin_marsh_agrees_with_francois_garrison_where_magnesium_sulphate_rules() {
    // Both fit the magnesium sulphate relaxation: from 20 to 50 kHz they
    // agree within 20 % at 4-20 C. Below 5 kHz Schulkin and Marsh leave
    // out boric acid and absorb less than half as much. Read as dB per
    // kiloyard, their formula would sit 9.4 % higher at 4 C, 20-25 kHz,
    // where the two now agree within 3 %.
    for t in [4.0, 10.0, 20.0] {
        let water = Water {
            temperature_c: t,
            ..Water::default()
        };
        for f in [20.0, 25.0, 50.0] {
            let ratio = schulkin_marsh_db_per_km(f, &water, 0.0)
                / francois_garrison_db_per_km(f, &water, 0.0);
            assert!((0.8..1.2).contains(&ratio), "{t} C, {f} kHz: {ratio}");
        }
        for f in [1.0, 2.0] {
            let ratio = schulkin_marsh_db_per_km(f, &water, 0.0)
                / francois_garrison_db_per_km(f, &water, 0.0);
            assert!(ratio < 0.5, "{t} C, {f} kHz: {ratio}");
        }
    }
    let cold = Water::default();
    for f in [20.0, 25.0] {
        let ratio =
            schulkin_marsh_db_per_km(f, &cold, 0.0) / francois_garrison_db_per_km(f, &cold, 0.0);
        assert!((ratio - 1.0).abs() < 0.03, "{f} kHz: {ratio}");
    }
}

#[test]
fn the_books_absorption_table_at_the_spirals_carrier_holds() {
    // docs/src/acoustic.md: 12 kHz, 4 C, 35 psu, pH 8, at the surface.
    let water = Water::default();
    let round3 = |x: f64| (x * 1000.0).round() / 1000.0;
    assert_relative_eq!(round3(thorp_db_per_km(12.0)), 1.645, max_relative = 1e-12);
    assert_relative_eq!(
        round3(francois_garrison_db_per_km(12.0, &water, 0.0)),
        1.595,
        max_relative = 1e-12
    );
    assert_relative_eq!(
        round3(schulkin_marsh_db_per_km(12.0, &water, 0.0)),
        1.456,
        max_relative = 1e-12
    );
}

#[test]
fn coates_noise_sums_its_four_components_in_power() {
    let c = coates_components_db(1.0, 0.5, 0.0);
    for (got, want) in c
        .iter()
        .zip([17.0, 39.229_766_517_689_67, 44.154_878_572_870_48, -15.0])
    {
        assert_relative_eq!(*got, want, max_relative = 1e-13);
    }
    let noise = |s: f64, w: f64| Noise::Coates {
        shipping: s,
        wind_mps: w,
    };
    assert_relative_eq!(
        noise(0.5, 0.0).density_db(1.0),
        45.372_625_068_378_255,
        max_relative = 1e-13
    );
    assert_relative_eq!(
        noise(1.0, 10.0).density_db(10.0),
        53.036_662_251_285_364,
        max_relative = 1e-13
    );
    // Thermal noise dominates at 100 kHz on a calm sea without ships.
    assert_relative_eq!(
        noise(0.0, 0.0).density_db(100.0),
        25.133_102_596_045_54,
        max_relative = 1e-13
    );
}

#[test]
fn the_band_noise_is_the_density_integrated_over_the_band() {
    // Constant: level + 10 log10(B) exactly.
    let flat = Noise::Constant { level_db: 50.0 };
    assert_relative_eq!(
        flat.band_db(12.0, 4.0),
        50.0 + 10.0 * 4000f64.log10(),
        max_relative = 1e-15
    );
    // Coates against a 200,000-point midpoint sum.
    let sea = Noise::Coates {
        shipping: 0.5,
        wind_mps: 0.0,
    };
    assert_relative_eq!(
        sea.band_db(12.0, 4.0),
        64.021_802_382_493_14,
        max_relative = 1e-8
    );
    let windy = Noise::Coates {
        shipping: 0.8,
        wind_mps: 5.0,
    };
    assert_relative_eq!(
        windy.band_db(2.0, 3.0),
        93.525_490_781_095_83,
        max_relative = 1e-7
    );
}

#[test]
fn out_of_range_water_and_noise_are_refused_naming_the_key() {
    let hot = Water {
        temperature_c: 60.0,
        ..Water::default()
    };
    assert_eq!(
        hot.validate("channel.loss.water").unwrap_err().key,
        "channel.loss.water.temperature_c"
    );
    let gale = Noise::Coates {
        shipping: 0.5,
        wind_mps: 80.0,
    };
    assert_eq!(
        gale.validate("channel.loss.noise").unwrap_err().key,
        "channel.loss.noise.wind_mps"
    );
}
