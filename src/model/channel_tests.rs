//! Unit tests of the acoustic channel on hand-built timelines and against
//! closed forms.

use super::*;
use crate::model::xy::Pt;
use approx::assert_relative_eq;

/// Nodes on the x axis at `xs` metres, each linked to the others.
fn line(cfg: AcousticCfg, xs: &[f64]) -> Medium {
    let n = xs.len() as u32;
    let links: Vec<Vec<u32>> = (0..n)
        .map(|i| (0..n).filter(|&j| j != i).collect())
        .collect();
    Medium::new(cfg, 7, xs.iter().map(|&x| Pt::xy(x, 0.0)).collect(), &links)
}

/// Ideal but for the rule under test.
fn quiet() -> AcousticCfg {
    AcousticCfg {
        half_duplex: false,
        collisions: false,
        ..AcousticCfg::default()
    }
}

#[test]
fn thorp_absorption_matches_the_formula_at_12_khz_and_grows_with_frequency() {
    // 0.11 * 144/145 + 44 * 144/4244 + 2.75e-4 * 144 + 0.003.
    let want = 0.11 * 144.0 / 145.0 + 44.0 * 144.0 / 4244.0 + 0.0396 + 0.003;
    assert_relative_eq!(thorp_db_per_km(12.0), want, max_relative = 1e-14);
    assert_relative_eq!(thorp_db_per_km(12.0), 1.644775, max_relative = 1e-5);
    assert!(thorp_db_per_km(1.0) < thorp_db_per_km(10.0));
    // 1 km, spherical spreading: 60 dB plus one km of absorption.
    assert_relative_eq!(
        transmission_loss_db(1000.0, 12.0, 2.0),
        60.0 + thorp_db_per_km(12.0),
        max_relative = 1e-14
    );
}

#[test]
fn the_bpsk_bit_error_rate_is_half_at_no_snr_and_falls_with_it() {
    assert_relative_eq!(bpsk_ber(0.0, 4000.0, 1000.0), 0.5, max_relative = 1e-15);
    // Eb/N0 = SNR B / R = 4: 1/2 erfc(2) = 2.339e-3.
    assert_relative_eq!(
        bpsk_ber(1.0, 4000.0, 1000.0),
        0.5 * 4.677_734_981_047_266e-3,
        max_relative = 1e-12
    );
}

#[test]
fn a_frame_arrives_after_the_distance_over_the_sound_speed_plus_its_own_length() {
    let cfg = quiet();
    let bits = cfg.frame_bits(4);
    assert_eq!(bits, 48 + 4 * 64);
    let mut m = line(cfg, &[0.0, 1500.0, 3300.0]);
    let f = m.send(nanos(2.0), 0, 2, bits);
    // In integer nanoseconds: 2 s, then 2.2 s of sound, then 0.304 s on the air.
    assert_eq!(f.arrive_start, 4_200_000_000);
    assert_eq!(f.arrive_end, 4_200_000_000 + 304_000_000);
    assert_eq!(m.judge(&f), Fate::Delivered);
    // The modem sends one frame at a time: the next one waits for it.
    let g = m.send(nanos(2.0), 0, 1, bits);
    assert_eq!(g.t_start, 2_304_000_000);
    assert_eq!(g.arrive_start, g.t_start + 1_000_000_000);
}

#[test]
fn a_frame_that_arrives_while_its_receiver_transmits_is_lost_to_half_duplex() {
    let cfg = AcousticCfg {
        half_duplex: true,
        ..quiet()
    };
    let mut m = line(cfg.clone(), &[0.0, 1500.0]);
    // 1 -> 0 arrives over [1, 1.1); node 0 transmits over [1.05, 1.15).
    let a = m.send(nanos(0.0), 1, 0, 100);
    let b = m.send(nanos(1.05), 0, 1, 100);
    assert_eq!(m.judge(&a), Fate::Lost(Reason::HalfDuplex));
    // 0 -> 1 arrives over [2.05, 2.15), after node 1 finished at 0.1.
    assert_eq!(m.judge(&b), Fate::Delivered);
    // Just after the arrival ends there is no overlap.
    let mut m = line(cfg, &[0.0, 1500.0]);
    let a = m.send(nanos(0.0), 1, 0, 100);
    m.send(nanos(1.1), 0, 1, 100);
    assert_eq!(m.judge(&a), Fate::Delivered);
}

#[test]
fn frames_that_overlap_at_a_receiver_are_both_lost_to_collision() {
    let cfg = AcousticCfg {
        collisions: true,
        ..quiet()
    };
    // Nodes at 0, 1500 and 3000 m: 0 and 2 are 1 s from node 1.
    let mut m = line(cfg.clone(), &[0.0, 1500.0, 3000.0]);
    let a = m.send(nanos(0.0), 0, 1, 100);
    let b = m.send(nanos(0.05), 2, 1, 100);
    assert_eq!(m.judge(&a), Fate::Lost(Reason::Collision));
    assert_eq!(m.judge(&b), Fate::Lost(Reason::Collision));
    // 0.1 s apart they do not overlap.
    let mut m = line(cfg.clone(), &[0.0, 1500.0, 3000.0]);
    let a = m.send(nanos(0.0), 0, 1, 100);
    let b = m.send(nanos(0.1), 2, 1, 100);
    assert_eq!(
        (m.judge(&a), m.judge(&b)),
        (Fate::Delivered, Fate::Delivered)
    );
    // A frame overheard by node 1 (2 -> 0 passes node 1) collides too.
    let mut m = line(cfg, &[0.0, 1500.0, 3000.0]);
    let a = m.send(nanos(0.0), 0, 1, 100);
    m.send(nanos(0.05), 2, 0, 100);
    assert_eq!(m.judge(&a), Fate::Lost(Reason::Collision));
}

#[test]
fn a_blocked_link_loses_everything_and_a_link_delay_adds_up() {
    let cfg = AcousticCfg {
        links: vec![
            LinkOverride {
                a: 1,
                b: 0,
                loss_p: None,
                extra_delay_s: 0.0,
                blocked: true,
            },
            LinkOverride {
                a: 1,
                b: 2,
                loss_p: None,
                extra_delay_s: 0.25,
                blocked: false,
            },
        ],
        ..quiet()
    };
    let mut m = line(cfg, &[0.0, 1500.0, 3000.0]);
    let f = m.send(nanos(0.0), 0, 1, 100);
    assert_eq!(m.judge(&f), Fate::Lost(Reason::Blocked));
    let g = m.send(nanos(0.0), 2, 1, 100);
    assert_eq!(g.arrive_start, 1_250_000_000);
    assert_eq!(m.judge(&g), Fate::Delivered);
}

#[test]
fn bernoulli_loss_lies_within_the_999_per_mille_binomial_interval() {
    let p = 0.2;
    let cfg = AcousticCfg {
        loss: LossCfg::Bernoulli { p },
        ..quiet()
    };
    let mut m = line(cfg, &[0.0, 1500.0]);
    let n = 20_000;
    let lost = (0..n)
        .filter(|k| {
            let f = m.send(nanos(*k as f64), 0, 1, 100);
            m.judge(&f) == Fate::Lost(Reason::Loss)
        })
        .count();
    // Normal approximation: z = 3.29 for 99.9 %.
    let sd = (p * (1.0 - p) / n as f64).sqrt();
    let rate = lost as f64 / n as f64;
    assert!(
        (rate - p).abs() < 3.29 * sd,
        "{rate} vs {p} +- {}",
        3.29 * sd
    );
}

#[test]
fn a_frame_fate_depends_only_on_the_seed_the_link_and_its_number() {
    let a = fate_draw(5, 0, 1, 17);
    assert_eq!(a.to_bits(), fate_draw(5, 0, 1, 17).to_bits());
    assert!((0.0..1.0).contains(&a));
    for other in [
        fate_draw(6, 0, 1, 17),
        fate_draw(5, 1, 0, 17),
        fate_draw(5, 0, 1, 18),
    ] {
        assert_ne!(a.to_bits(), other.to_bits());
    }
    // Other traffic does not change a frame's fate.
    let cfg = AcousticCfg {
        loss: LossCfg::Bernoulli { p: 0.5 },
        ..quiet()
    };
    let mut m1 = line(cfg.clone(), &[0.0, 1500.0, 3000.0]);
    let mut m2 = line(cfg, &[0.0, 1500.0, 3000.0]);
    let fates1: Vec<Fate> = (0..50)
        .map(|k| {
            let f = m1.send(nanos(k as f64), 0, 1, 100);
            m1.judge(&f)
        })
        .collect();
    let fates2: Vec<Fate> = (0..50)
        .map(|k| {
            m2.send(nanos(k as f64), 2, 1, 100);
            let f = m2.send(nanos(k as f64), 0, 1, 100);
            m2.judge(&f)
        })
        .collect();
    assert_eq!(fates1, fates2);
}

#[test]
fn range_loss_grows_with_the_link_length() {
    let cfg = AcousticCfg {
        loss: LossCfg::Range {
            carrier_khz: 12.0,
            bandwidth_khz: 4.0,
            source_level_db: 170.0,
            noise_level_db: 50.0,
            spreading: 1.5,
            absorption: crate::model::acoustics::Absorption::Thorp,
            water: None,
            noise: None,
        },
        ..quiet()
    };
    let bits = cfg.frame_bits(4);
    let p = |d: f64| cfg.loss_probability(0, 1, &Pt::xy(0.0, 0.0), &Pt::xy(d, 0.0), bits);
    assert!(p(100.0) < 1e-12, "{}", p(100.0));
    assert!(p(50_000.0) > 0.999, "{}", p(50_000.0));
    let mut last = 0.0;
    for d in [1000.0, 2000.0, 4000.0, 8000.0, 12000.0, 16000.0] {
        assert!(p(d) >= last, "not monotone at {d}");
        last = p(d);
    }
}

#[test]
fn every_number_is_checked_against_its_range_naming_the_key() {
    let bad = |cfg: AcousticCfg| cfg.validate(3).unwrap_err();
    assert!(AcousticCfg::default().validate(3).is_ok());
    let e = bad(AcousticCfg {
        sound_speed: 0.0,
        ..AcousticCfg::default()
    });
    assert_eq!(e.key, "channel.sound_speed");
    let e = bad(AcousticCfg {
        loss: LossCfg::Bernoulli { p: 1.5 },
        ..AcousticCfg::default()
    });
    assert_eq!(e.key, "channel.loss.p");
    let link = LinkOverride {
        a: 0,
        b: 3,
        loss_p: None,
        extra_delay_s: 0.0,
        blocked: false,
    };
    let e = bad(AcousticCfg {
        links: vec![link],
        ..AcousticCfg::default()
    });
    assert_eq!(e.key, "channel.links[0].b");
    assert!(e.reason.contains("node 3 does not exist"), "{}", e.reason);
    let e = bad(AcousticCfg {
        bit_rate: f64::NAN,
        ..AcousticCfg::default()
    });
    assert_eq!(e.key, "channel.bit_rate");
    // The TOML form, with its defaults and deny_unknown_fields.
    let cfg: AcousticCfg =
        toml::from_str("bit_rate = 500.0\nloss = { model = \"bernoulli\", p = 0.2 }\n").unwrap();
    assert_eq!(cfg.loss, LossCfg::Bernoulli { p: 0.2 });
    assert_relative_eq!(cfg.sound_speed, 1500.0);
    assert!(toml::from_str::<AcousticCfg>("bitrate = 500.0\n").is_err());
    // [channel]: ideal takes no other key; acoustic takes the keys above.
    let ideal: ChannelCfg = toml::from_str("model = \"ideal\"\n").unwrap();
    assert_eq!(ideal, ChannelCfg::Ideal {});
    assert!(toml::from_str::<ChannelCfg>("model = \"ideal\"\nbit_rate = 5.0\n").is_err());
    let ac: ChannelCfg = toml::from_str("model = \"acoustic\"\nbit_rate = 500.0\n").unwrap();
    assert_relative_eq!(ac.acoustic().map_or(0.0, |a| a.bit_rate), 500.0);
    assert!(toml::from_str::<ChannelCfg>("model = \"acoustic\"\nbitrate = 5.0\n").is_err());
}

#[test]
fn forgetting_the_past_does_not_change_a_later_judgement() {
    let cfg = AcousticCfg::default();
    let mut a = line(cfg.clone(), &[0.0, 1500.0, 3000.0]);
    let mut b = line(cfg, &[0.0, 1500.0, 3000.0]);
    let mut fates = (Vec::new(), Vec::new());
    for k in 0..40 {
        let t = k as f64 * 0.13;
        let (from, to) = ((k % 3) as u32, ((k + 1) % 3) as u32);
        let fa = a.send(nanos(t), from, to, 200);
        let fb = b.send(nanos(t), from, to, 200);
        b.forget_before(nanos(t - 5.0));
        fates.0.push(a.judge(&fa));
        fates.1.push(b.judge(&fb));
    }
    assert_eq!(fates.0, fates.1);
    assert!(fates.0.iter().any(|f| *f != Fate::Delivered));
}

#[test]
fn intervals_that_meet_at_one_nanosecond_do_not_overlap_whatever_the_distances() {
    // Delays that are no round number of seconds (0.823044667 s and
    // 0.518466667 s once rounded to the nanosecond); node 2 off the line
    // through 0 and 1.
    let pos = vec![
        Pt::xy(0.0, 0.0),
        Pt::xy(1234.567, 0.0),
        Pt::xy(1234.567, 777.7),
    ];
    let links = vec![vec![1, 2], vec![0, 2], vec![0, 1]];
    let cfg = AcousticCfg {
        half_duplex: true,
        collisions: true,
        ..quiet()
    };
    let medium = |cfg: AcousticCfg| Medium::new(cfg, 7, pos.clone(), &links);
    let mut m = medium(cfg.clone());
    let a = m.send(0, 0, 1, 100);
    assert_eq!(a.arrive_end, m.delay_ns(0, 1) + 100_000_000);
    // Node 1 starts to transmit the instant a's arrival ends, and a frame
    // from node 2 starts to arrive at node 1 at that instant.
    let b = m.send(a.arrive_end, 1, 0, 100);
    let c = m.send(a.arrive_end - m.delay_ns(2, 1), 2, 1, 100);
    assert_eq!(c.arrive_start, a.arrive_end);
    assert_eq!(m.judge(&a), Fate::Delivered);
    assert_eq!(m.judge(&b), Fate::Delivered);
    // c arrives at node 1 while node 1 transmits b: half-duplex.
    assert_eq!(m.judge(&c), Fate::Lost(Reason::HalfDuplex));
    // One nanosecond earlier, they overlap.
    let mut m = medium(cfg);
    let a = m.send(0, 0, 1, 100);
    m.send(a.arrive_end - 1, 1, 0, 100);
    assert_eq!(m.judge(&a), Fate::Lost(Reason::HalfDuplex));
}

#[test]
fn seconds_become_nanoseconds_rounded_to_the_nearest_and_never_negative() {
    assert_eq!(nanos(1.5), 1_500_000_000);
    assert_eq!(nanos(0.823_044_666_7), 823_044_667);
    assert_eq!(nanos(-2.0), 0);
    assert_eq!(nanos(f64::NAN), 0);
    assert_eq!(nanos(f64::INFINITY), u64::MAX);
    assert_eq!(seconds(1_500_000_000).to_bits(), 1.5f64.to_bits());
}

#[test]
fn the_range_loss_takes_francois_garrison_at_the_path_depth_and_coates_noise() {
    let cfg = |extra: &str| -> AcousticCfg {
        let text = format!(
            "model = \"acoustic\"\nloss = {{ model = \"range\", carrier_khz = 20.0, source_level_db = 160.0{extra} }}\n"
        );
        match toml::from_str::<ChannelCfg>(&text).expect("parses") {
            ChannelCfg::Acoustic(a) => {
                a.validate(2).expect("valid");
                a
            }
            ChannelCfg::Ideal {} => panic!("acoustic"),
        }
    };
    let bits = 400;
    let p = |c: &AcousticCfg, a: Pt, b: Pt| c.loss_probability(0, 1, &a, &b, bits);
    // Francois-Garrison absorbs less at depth (pressure), so a deep 3-D
    // path loses fewer frames than the same path near the surface.
    let fg = cfg(", absorption = \"francois_garrison\", water = { temperature_c = 10.0 }");
    let (near, deep) = (
        p(&fg, Pt::xyz(0.0, 0.0, -10.0), Pt::xyz(6000.0, 0.0, -10.0)),
        p(
            &fg,
            Pt::xyz(0.0, 0.0, -3000.0),
            Pt::xyz(6000.0, 0.0, -3000.0),
        ),
    );
    assert!(deep < near, "deep {deep} near {near}");
    // A 2-D path takes water.depth_m.
    let fg_deep = cfg(
        ", absorption = \"francois_garrison\", water = { temperature_c = 10.0, depth_m = 3000.0 }",
    );
    let flat = p(&fg_deep, Pt::xy(0.0, 0.0), Pt::xy(6000.0, 0.0));
    assert!(
        (flat - deep).abs() <= 1e-12 * deep.max(1e-300),
        "{flat} vs {deep}"
    );
    // Schulkin-Marsh too takes the water and the path's depth.
    let sm = cfg(", absorption = \"marsh_schulkin\", water = { temperature_c = 10.0 }");
    let (sm_near, sm_deep) = (
        p(&sm, Pt::xyz(0.0, 0.0, -10.0), Pt::xyz(6000.0, 0.0, -10.0)),
        p(
            &sm,
            Pt::xyz(0.0, 0.0, -3000.0),
            Pt::xyz(6000.0, 0.0, -3000.0),
        ),
    );
    assert!(sm_deep < sm_near, "deep {sm_deep} near {sm_near}");
    assert!((sm_near - near).abs() > 1e-6, "{sm_near} vs {near}");
    // A shipping lane and a gale are louder than a calm empty sea.
    let calm = cfg(", noise = { model = \"coates\", shipping = 0.0, wind_mps = 0.0 }");
    let rough = cfg(", noise = { model = \"coates\", shipping = 1.0, wind_mps = 20.0 }");
    let (a, b) = (Pt::xy(0.0, 0.0), Pt::xy(5000.0, 0.0));
    assert!(p(&rough, a, b) > p(&calm, a, b));
    // The constant model is the flat noise_level_db.
    let flat_noise = cfg(", noise = { model = \"constant\", level_db = 60.0 }");
    let legacy = cfg(", noise_level_db = 60.0");
    assert_eq!(p(&flat_noise, a, b).to_bits(), p(&legacy, a, b).to_bits());
    // Water only means something to Francois-Garrison and Schulkin-Marsh.
    let text = "model = \"acoustic\"\nloss = { model = \"range\", water = { ph = 7.5 } }\n";
    let Ok(ChannelCfg::Acoustic(thorp)) = toml::from_str::<ChannelCfg>(text) else {
        panic!("parses");
    };
    assert_eq!(thorp.validate(2).unwrap_err().key, "channel.loss.water");
}

/// A loud modem on the range loss (no bit errors at these distances) under
/// the SINR rule with the given threshold and detection level.
fn sinr(threshold_db: f64, detection_db: f64) -> AcousticCfg {
    AcousticCfg {
        loss: LossCfg::Range {
            carrier_khz: 12.0,
            bandwidth_khz: 4.0,
            source_level_db: 200.0,
            noise_level_db: 50.0,
            spreading: 1.5,
            absorption: Absorption::Thorp,
            water: None,
            noise: None,
        },
        reception: Reception::Sinr {
            threshold_db,
            detection_db,
        },
        ..AcousticCfg::default()
    }
}

/// Nodes on the x axis at `xs`, linked along `edges` only.
fn graph(cfg: AcousticCfg, xs: &[f64], edges: &[(u32, u32)]) -> Medium {
    let mut links = vec![Vec::new(); xs.len()];
    for &(a, b) in edges {
        links[a as usize].push(b);
        links[b as usize].push(a);
    }
    Medium::new(cfg, 7, xs.iter().map(|&x| Pt::xy(x, 0.0)).collect(), &links)
}

#[test]
fn under_sinr_a_strong_frame_captures_the_receiver_and_the_weak_one_is_lost() {
    // A (0 m) and C (3000 m) send to B (100 m) at once: A is about 27 dB
    // louder at B.
    let cfg = sinr(10.0, 3.0);
    let bits = cfg.frame_bits(4);
    let mut m = line(cfg.clone(), &[0.0, 100.0, 3000.0]);
    let delay_c = m.delay_ns(2, 1) - m.delay_ns(0, 1);
    let fa = m.send(delay_c, 0, 1, bits);
    let fc = m.send(0, 2, 1, bits);
    assert_eq!(fa.arrive_start, fc.arrive_start, "the arrivals coincide");
    assert_eq!(m.judge(&fa), Fate::Delivered);
    assert_eq!(m.judge(&fc), Fate::Lost(Reason::Collision));
    // The recorded SINR is the closed form: A's power over the noise and C's.
    let (la, n) = cfg
        .levels_db(&Pt::xy(0.0, 0.0), &Pt::xy(100.0, 0.0))
        .unwrap();
    let (lc, _) = cfg
        .levels_db(&Pt::xy(3000.0, 0.0), &Pt::xy(100.0, 0.0))
        .unwrap();
    let p = |db: f64| 10f64.powf(db / 10.0);
    let want = 10.0 * (p(la) / (p(n) + p(lc))).log10();
    assert_relative_eq!(m.sinr_db(&fa).unwrap(), want, max_relative = 1e-12);
    assert!(want > 25.0, "{want}");
    // The graph rule loses both.
    let mut g = line(
        AcousticCfg {
            reception: Reception::Graph {},
            ..cfg
        },
        &[0.0, 100.0, 3000.0],
    );
    let fa = g.send(delay_c, 0, 1, bits);
    let fc = g.send(0, 2, 1, bits);
    assert_eq!(g.judge(&fa), Fate::Lost(Reason::Collision));
    assert_eq!(g.judge(&fc), Fate::Lost(Reason::Collision));
    assert_eq!(g.sinr_db(&fa), None);
}

#[test]
fn under_sinr_an_interferer_outside_the_gossip_graph_still_collides() {
    // A (0 m) -> B (100 m) while C (200 m), linked only to D, sends to D:
    // C is as loud as A at B.
    let edges = [(0, 1), (2, 3)];
    let xs = [0.0, 100.0, 200.0, 300.0];
    for (cfg, fate) in [
        (sinr(10.0, 3.0), Fate::Lost(Reason::Collision)),
        (
            AcousticCfg {
                reception: Reception::Graph {},
                ..sinr(10.0, 3.0)
            },
            Fate::Delivered,
        ),
    ] {
        let bits = cfg.frame_bits(4);
        let mut m = graph(cfg, &xs, &edges);
        let fa = m.send(0, 0, 1, bits);
        let _fc = m.send(0, 2, 3, bits);
        assert_eq!(m.judge(&fa), fate);
    }
}

#[test]
fn under_sinr_an_interferer_below_the_detection_level_does_not_count() {
    // C is as loud as A at B, both about 84 dB over the noise: with
    // detection at 90 dB over the noise C is not counted.
    let xs = [0.0, 100.0, 200.0];
    for (detection, fate) in [
        (3.0, Fate::Lost(Reason::Collision)),
        (90.0, Fate::Delivered),
    ] {
        let cfg = sinr(10.0, detection);
        let bits = cfg.frame_bits(4);
        let mut m = line(cfg, &xs);
        let fa = m.send(0, 0, 1, bits);
        let _fc = m.send(0, 2, 1, bits);
        assert_eq!(m.judge(&fa), fate, "detection {detection} dB");
    }
}

#[test]
fn under_sinr_a_frame_too_weak_for_the_threshold_alone_is_lost_to_noise() {
    // A threshold above the SNR: lost as `loss`, with no interferer.
    let cfg = sinr(95.0, 3.0);
    let bits = cfg.frame_bits(4);
    let mut m = line(cfg, &[0.0, 100.0]);
    let f = m.send(0, 0, 1, bits);
    assert_eq!(m.judge(&f), Fate::Lost(Reason::Loss));
}

#[test]
fn the_sinr_rule_is_refused_without_the_range_loss_that_gives_its_levels() {
    let cfg = AcousticCfg {
        reception: Reception::Sinr {
            threshold_db: 10.0,
            detection_db: 3.0,
        },
        ..AcousticCfg::default()
    };
    assert_eq!(
        cfg.validate(2).expect_err("no levels").key,
        "channel.reception"
    );
    assert!(sinr(10.0, 3.0).validate(2).is_ok());
}

#[test]
fn under_tdma_no_frame_can_collide_or_meet_a_transmitting_receiver() {
    // Six nodes on a path 0-1-2-3-4-5, 1 km apart, each sending to a
    // neighbour at pseudo-random times: every frame is delivered.
    let cfg = AcousticCfg {
        mac: crate::model::mac::Mac::Tdma { slot_s: None },
        ..AcousticCfg::default()
    };
    let xs: Vec<f64> = (0..6).map(|k| 1000.0 * k as f64).collect();
    let edges: Vec<(u32, u32)> = (0..5).map(|k| (k, k + 1)).collect();
    let bits = cfg.frame_bits(3);
    // The fates of the same scrambled senders and times on `cfg`.
    let fates = |cfg: AcousticCfg| -> Vec<Fate> {
        let mut m = graph(cfg, &xs, &edges);
        let mut t: u64 = 0;
        let frames: Vec<Frame> = (0..300u64)
            .map(|k| {
                let from = ((k * 7 + 3) % 6) as u32;
                let to = if from == 0 || (from < 5 && k % 2 == 0) {
                    from + 1
                } else {
                    from - 1
                };
                t += (k * 7_919) % 900_000_000;
                m.send(t, from, to, bits)
            })
            .collect();
        frames.iter().map(|f| m.judge(f)).collect()
    };
    let tdma = fates(cfg);
    assert!(tdma.iter().all(|f| *f == Fate::Delivered), "{tdma:?}");
    // The same traffic under ALOHA collides.
    let lost = fates(AcousticCfg::default())
        .iter()
        .filter(|f| **f != Fate::Delivered)
        .count();
    assert!(lost > 10, "{lost} lost under ALOHA");
}

#[test]
fn a_tdma_slot_too_short_for_the_longest_frame_and_delay_is_refused_naming_its_key() {
    let cfg = AcousticCfg {
        mac: crate::model::mac::Mac::Tdma { slot_s: Some(0.5) },
        ..AcousticCfg::default()
    };
    let pos = [Pt::xy(0.0, 0.0), Pt::xy(1500.0, 0.0)];
    let links = vec![vec![1], vec![0]];
    // 240 bits at 1000 bit/s and 1 s of sound: 1.24 s at least.
    assert_relative_eq!(cfg.min_slot_s(&pos, &links), 1.24, max_relative = 1e-12);
    assert_eq!(
        cfg.check_slot(&pos, &links).expect_err("too short").key,
        "channel.mac.slot_s"
    );
}
