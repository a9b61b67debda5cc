//! Absorption and noise against values computed independently (in Python,
//! from the formulas as MB-System's `mbabsorption` documents Francois and
//! Garrison 1982 and as Stojanovic 2007 eq. (3) and (7) give Thorp and
//! Coates) and against each other.

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
