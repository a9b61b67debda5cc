//! One sample's bistatic least-squares problem (Shi 2024 eq. (1)-(2)): its
//! linearisation, the linear initialisation and the iterate updates shared by the
//! estimators.

use super::Init;
use crate::estimators::robust::BistaticLink;
use crate::estimators::robust::RobustError;
use crate::model::geometry::Point;
use crate::model::measure::Geometry;

/// The links resolved to sensor positions, validated.
pub(super) struct Problem<const D: usize = 2> {
    pub(super) t: Vec<Point<D>>,
    pub(super) r: Vec<Point<D>>,
    pub(super) s: Vec<f64>,
    pub(super) rx: Vec<usize>,
    pub(super) n_rx: usize,
    pub(super) centroid: Point<D>,
    /// RMS distance of the sensors from their centroid (floored).
    pub(super) spread: f64,
    /// Distances below this are clamped (Lemma 1/2 of Shi 2024 divide by them).
    pub(super) dist_floor: f64,
}

impl<const D: usize> Problem<D> {
    pub(super) fn new(
        geom: &Geometry<D>,
        links: &[BistaticLink],
    ) -> Result<Problem<D>, RobustError> {
        if links.is_empty() {
            return Err(RobustError::NoLinks);
        }
        let (n_tx, n_rx) = (geom.transmitters.len(), geom.receivers.len());
        let mut t = Vec::with_capacity(links.len());
        let mut r = Vec::with_capacity(links.len());
        let mut s = Vec::with_capacity(links.len());
        let mut rx = Vec::with_capacity(links.len());
        for (index, l) in links.iter().enumerate() {
            let tp = *geom
                .transmitters
                .get(l.tx)
                .ok_or(RobustError::TransmitterOutOfRange {
                    index,
                    tx: l.tx,
                    n_tx,
                })?;
            let rp = *geom
                .receivers
                .get(l.rx)
                .ok_or(RobustError::ReceiverOutOfRange {
                    index,
                    rx: l.rx,
                    n_rx,
                })?;
            if !tp.iter().all(|v| v.is_finite()) {
                return Err(RobustError::NonFiniteSensor {
                    kind: "transmitter",
                    index: l.tx,
                });
            }
            if !rp.iter().all(|v| v.is_finite()) {
                return Err(RobustError::NonFiniteSensor {
                    kind: "receiver",
                    index: l.rx,
                });
            }
            if !l.rho.is_finite() {
                return Err(RobustError::NonFiniteRange { index, rho: l.rho });
            }
            t.push(tp);
            r.push(rp);
            s.push(l.rho);
            rx.push(l.rx);
        }
        let n = links.len() as f64;
        let centroid = (t.iter().sum::<Point<D>>() + r.iter().sum::<Point<D>>()) / (2.0 * n);
        let ms = t
            .iter()
            .chain(r.iter())
            .map(|p| (p - centroid).norm_squared())
            .sum::<f64>()
            / (2.0 * n);
        let mean_s = s.iter().map(|v| v.abs()).sum::<f64>() / n;
        let spread = ms.sqrt().max(0.5 * mean_s).max(f64::MIN_POSITIVE);
        if !spread.is_finite() {
            return Err(RobustError::NonFinite {
                estimator: "input",
                iter: 0,
            });
        }
        Ok(Problem {
            t,
            r,
            s,
            rx,
            n_rx,
            centroid,
            spread,
            dist_floor: 1e-12 * spread,
        })
    }

    pub(super) fn len(&self) -> usize {
        self.s.len()
    }

    pub(super) fn step_floor(&self) -> f64 {
        1e-3 * self.spread
    }

    pub(super) fn init(&self, init: Init) -> Result<Point<D>, RobustError> {
        match init {
            Init::Point(_) if D != 2 => Err(RobustError::InvalidConfig {
                key: "init",
                reason:
                    "a given point is [x, y]: a 3-D problem starts from \"linear\" or \"centroid\""
                        .into(),
            }),
            Init::Point([x, y]) => {
                if x.is_finite() && y.is_finite() {
                    Ok(Point::<D>::from_fn(|i, _| if i == 0 { x } else { y }))
                } else {
                    Err(RobustError::NonFiniteInit(x, y))
                }
            }
            Init::Centroid => Ok(self.centroid),
            Init::Linear => Ok(self.linear_init().unwrap_or(self.centroid)),
        }
    }

    /// Linear LS on the rows `[2 (t - r)^T, -2 s] [e; d_j] = ||t||^2 - s^2 - ||r||^2`
    /// of Mourya 2017 eq. (9), each receiver's `d_j` lifted
    /// ([`crate::estimators::online::lifted_bistatic_ls`], centred on the sensor
    /// centroid). `None` if singular.
    pub(super) fn linear_init(&self) -> Option<Point<D>> {
        let rows = (0..self.len()).map(|l| crate::estimators::online::LiftedRow {
            key: self.rx[l],
            lift: self.r[l],
            other: self.t[l],
            rho: self.s[l],
        });
        crate::estimators::online::lifted_bistatic_ls(rows, self.n_rx, self.centroid)
    }
}

/// Hard thresholding of Shi 2024 eq. (19)-(20), the one implementation for
/// `l0-OS` here and the `gtrs_l0` prox ([`crate::estimators::prox::l0`]): the indices of
/// the `kappa` largest `|beta|`, ascending. Ties go to the lower index, so the
/// result is deterministic (Shi 2024 allows any tie-break); a NaN counts as
/// infinitely large, so a poisoned entry is separated first. `order` is
/// scratch and holds the result.
pub(crate) fn hard_threshold<'a>(
    beta: &[f64],
    kappa: usize,
    order: &'a mut Vec<usize>,
) -> &'a [usize] {
    order.clear();
    order.extend(0..beta.len());
    let k = kappa.min(order.len());
    if k == 0 {
        return &order[..0];
    }
    let mag = |i: usize| {
        let m = beta[i].abs();
        if m.is_nan() { f64::INFINITY } else { m }
    };
    let cmp = |a: &usize, b: &usize| mag(*b).total_cmp(&mag(*a)).then_with(|| a.cmp(b));
    if k < order.len() {
        order.select_nth_unstable_by(k - 1, cmp);
    }
    order.truncate(k);
    order.sort_unstable();
    &order[..]
}
