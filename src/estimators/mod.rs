//! Every estimator of the target position, over the [`crate::model`] layer:
//!
//! * the distributed algorithm's local pieces: a node's cost ([`local`],
//!   Mourya 2017 eq. 9-10), its prox ([`prox`]: relaxed, GTRS, `gtrs_l0`) and the
//!   gossip [`gossip::Mode`];
//! * the centralised references and trackers: ML and CRLB ([`central`]),
//!   online OGD/ONM trackers (Pun-So 2022 and 2020, [`online`]), robust one-sample
//!   estimators (Shi 2024, [`robust`]) and certified bounds (Gholami 2015,
//!   [`bounds`]);
//! * [`track`]: the one problem/solver seam of the sequential estimators,
//!   with validated `with_*` builders and the executor [`track::run_track`];
//! * [`baselines`]: the configured baselines, each an adapter over that seam.

pub mod baselines;
pub mod bounds;
pub mod central;
pub mod gossip;
pub mod local;
pub mod online;
pub mod prox;
pub mod robust;
pub mod track;
