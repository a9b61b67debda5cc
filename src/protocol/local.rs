//! A node's local step in its run's dimension: the cost of Mourya 2017
//! eq. (9)-(10) built from the node's own measurements, and its prox
//! (eq. 11, first line) or first fix, on the [`Coords`] the protocol carries.
//!
//! The math is [`LocalProblem<D, L>`] and [`prox`], generic over the
//! dimension at compile time; a node learns its dimension at run time from
//! its [`NodeConfig`] (the anchor's coordinates), so [`LocalStep`] holds one
//! of the two instantiations and converts at its edges, bit for bit.

use super::NodeConfig;
use crate::estimators::local::LocalProblem;
use crate::estimators::prox::gtrs::ProxError;
use crate::estimators::prox::{LocalProx, prox};
use crate::model::coords::Coords;
use crate::model::geometry::{Point, check_dims};
use crate::model::measure::{NodeMeasurements, Sigmas};

/// The local cost of one dimension and the transmitters it is built with.
#[derive(Debug, Clone, PartialEq)]
pub struct Step<const D: usize, const L: usize> {
    problem: LocalProblem<D, L>,
    transmitters: Vec<Point<D>>,
}

impl<const D: usize, const L: usize> Step<D, L> {
    fn new(cfg: &NodeConfig) -> Self {
        const { check_dims::<D, L>() };
        Step {
            problem: LocalProblem::empty(cfg.anchor.point::<D>()),
            transmitters: cfg.transmitters.iter().map(|t| t.point::<D>()).collect(),
        }
    }

    fn build(&mut self, cfg: &NodeConfig, sample: u32, meas: &NodeMeasurements, sigmas: &Sigmas) {
        let anchor = match &cfg.drift {
            Some(d) => d.position(&cfg.anchor.point::<D>(), sample as usize),
            None => self.problem.anchor,
        };
        self.problem = LocalProblem::build_weighted(
            anchor,
            &self.transmitters,
            cfg.omega,
            meas,
            cfg.noise_weights.then_some(sigmas),
        );
    }

    fn first_fix(&self) -> Coords {
        Coords::of(&self.problem.first_fix(&self.transmitters))
    }

    fn prox(&self, solver: LocalProx, u: &Coords, gamma: f64) -> Result<Coords, ProxError> {
        prox(solver, &self.problem, &u.lifted::<L>(), gamma).map(|t| Coords::of(&t))
    }
}

/// A node's local step: 2-D (`theta~` in R^3) or 3-D (in R^4).
#[derive(Debug, Clone, PartialEq)]
pub enum LocalStep {
    /// A 2-D run.
    Plane(Step<2, 3>),
    /// A 3-D run.
    Space(Step<3, 4>),
}

impl LocalStep {
    /// No measurements yet, in the dimension of `cfg.anchor`.
    pub fn new(cfg: &NodeConfig) -> LocalStep {
        match cfg.anchor.dim() {
            3 => LocalStep::Space(Step::new(cfg)),
            _ => LocalStep::Plane(Step::new(cfg)),
        }
    }

    /// Replace the cost by that of sample `sample`'s measurements
    /// (eq. 9-10), at the node's position of that sample.
    pub fn build(
        &mut self,
        cfg: &NodeConfig,
        sample: u32,
        meas: &NodeMeasurements,
        sigmas: &Sigmas,
    ) {
        match self {
            LocalStep::Plane(s) => s.build(cfg, sample, meas, sigmas),
            LocalStep::Space(s) => s.build(cfg, sample, meas, sigmas),
        }
    }

    /// The node's own fix of the current sample
    /// ([`LocalProblem::first_fix`]).
    pub fn first_fix(&self) -> Coords {
        match self {
            LocalStep::Plane(s) => s.first_fix(),
            LocalStep::Space(s) => s.first_fix(),
        }
    }

    /// `prox_{gamma f_v}(u)` by `solver`.
    pub fn prox(&self, solver: LocalProx, u: &Coords, gamma: f64) -> Result<Coords, ProxError> {
        match self {
            LocalStep::Plane(s) => s.prox(solver, u, gamma),
            LocalStep::Space(s) => s.prox(solver, u, gamma),
        }
    }
}
