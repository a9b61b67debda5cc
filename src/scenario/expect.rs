//! `[expect]` checks: thresholds and relations between metrics.
//!
//! `holds` entries are relations `EXPR OP EXPR` with `OP` one of `<`, `<=`,
//! `>`, `>=`, or the exact `==` and `!=` (for counts and flags, such as
//! `faults.recovered == 3`), where `EXPR` is arithmetic (`+ - * /`,
//! parentheses, numbers) over metric names:
//!
//! * `TRACK.METRIC`: `TRACK` is `theta_bar` (the distributed estimate), `ml`
//!   (the centralised ML reference) or a baseline name; `METRIC` a key of
//!   [`crate::pipeline::score::TrackMetrics`] (`rmse`, `ctte`, `regret_pred`, ...);
//! * `TRACK.bounds.BOUND.METRIC`: a certified bound's metric (`coverage`, ...);
//! * in a Monte Carlo run a metric is its **mean** across trials; append
//!   `.rms`, `.median`, `.p5`, `.p95`, `.min` or `.max` for another statistic
//!   (`NAME.rmse.rms` of one-sample trials is the RMSE over trials).
//!
//! Example: `"onm.ctte < ogd.ctte"`, `"ogd.ctte_rate < ogd.ctte_rate_mid"`,
//! `"l0os.rmse < 0.9 * ls.rmse"`.

use serde::{Deserialize, Serialize};

/// `[expect]`: thresholds asserted by the scenario tests. Every key is optional.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct ExpectCfg {
    /// Upper bound on `rmse`.
    #[serde(default)]
    pub rmse_max: Option<f64>,
    /// Upper bound on `rmse_after_burn_in`.
    #[serde(default)]
    pub rmse_after_burn_in_max: Option<f64>,
    /// Upper bound on `median_error`.
    #[serde(default)]
    pub median_error_max: Option<f64>,
    /// Upper bound on `final_error`.
    #[serde(default)]
    pub final_error_max: Option<f64>,
    /// Upper bound on `max_disagreement`.
    #[serde(default)]
    pub max_disagreement_max: Option<f64>,
    /// Upper bound on `ml_rmse`.
    #[serde(default)]
    pub ml_rmse_max: Option<f64>,
    /// Relations that must hold, e.g. `"onm.ctte < ogd.ctte"` or
    /// `"theta_bar.bounds.upp_maxdis.coverage >= 1"` (see [`crate::scenario::expect`]).
    /// In a Monte Carlo run a metric is its mean across trials
    /// (`NAME.METRIC.median`, `.p5`, `.p95` select other statistics).
    #[serde(default)]
    pub holds: Vec<String>,
}

/// The outcome of one expectation.
#[derive(Debug, Clone, PartialEq)]
pub struct Check {
    /// The expectation as written (thresholds as `theta_bar.rmse <= 5`).
    pub text: String,
    /// Left and right values.
    pub lhs: f64,
    /// Right value.
    pub rhs: f64,
    /// Whether it holds.
    pub holds: bool,
}

/// An expectation that cannot be evaluated: the relation as written and
/// why (a syntax error, an unknown metric, a side that is not finite).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{relation}: {reason}")]
pub struct ExpectError {
    /// The relation (`theta_bar.rmse <= 20.0`).
    pub relation: String,
    /// Why it cannot be evaluated.
    pub reason: String,
}

#[derive(Debug, Clone, PartialEq)]
enum Tok {
    Num(f64),
    Ident(String),
    Op(char),
    Cmp(&'static str),
    LParen,
    RParen,
}

fn lex(s: &str) -> Result<Vec<Tok>, String> {
    let c: Vec<char> = s.chars().collect();
    let mut i = 0;
    let mut out = Vec::new();
    while i < c.len() {
        let ch = c[i];
        if ch.is_whitespace() {
            i += 1;
        } else if ch.is_ascii_digit()
            || (ch == '.' && c.get(i + 1).is_some_and(char::is_ascii_digit))
        {
            let start = i;
            while i < c.len()
                && (c[i].is_ascii_digit()
                    || c[i] == '.'
                    || c[i] == 'e'
                    || c[i] == 'E'
                    || ((c[i] == '-' || c[i] == '+') && matches!(c[i - 1], 'e' | 'E')))
            {
                i += 1;
            }
            let t: String = c[start..i].iter().collect();
            out.push(Tok::Num(
                t.parse().map_err(|_| format!("bad number {t:?}"))?,
            ));
        } else if ch.is_ascii_alphabetic() || ch == '_' {
            let start = i;
            while i < c.len() && (c[i].is_ascii_alphanumeric() || c[i] == '_' || c[i] == '.') {
                i += 1;
            }
            out.push(Tok::Ident(c[start..i].iter().collect()));
        } else if "+-*/".contains(ch) {
            out.push(Tok::Op(ch));
            i += 1;
        } else if ch == '(' {
            out.push(Tok::LParen);
            i += 1;
        } else if ch == ')' {
            out.push(Tok::RParen);
            i += 1;
        } else if ch == '<' || ch == '>' {
            let eq = c.get(i + 1) == Some(&'=');
            out.push(Tok::Cmp(match (ch, eq) {
                ('<', true) => "<=",
                ('<', false) => "<",
                ('>', true) => ">=",
                _ => ">",
            }));
            i += if eq { 2 } else { 1 };
        } else if (ch == '=' || ch == '!') && c.get(i + 1) == Some(&'=') {
            out.push(Tok::Cmp(if ch == '=' { "==" } else { "!=" }));
            i += 2;
        } else if ch == '=' {
            return Err("a single '=': write '==' for equality".into());
        } else {
            return Err(format!("unexpected character {ch:?}"));
        }
    }
    Ok(out)
}

struct Parser<'a, F: Fn(&str) -> Result<f64, String>> {
    toks: &'a [Tok],
    pos: usize,
    lookup: &'a F,
}

impl<F: Fn(&str) -> Result<f64, String>> Parser<'_, F> {
    fn peek(&self) -> Option<&Tok> {
        self.toks.get(self.pos)
    }
    fn expr(&mut self) -> Result<f64, String> {
        let mut v = self.term()?;
        while let Some(Tok::Op(op @ ('+' | '-'))) = self.peek().cloned() {
            self.pos += 1;
            let r = self.term()?;
            v = if op == '+' { v + r } else { v - r };
        }
        Ok(v)
    }
    fn term(&mut self) -> Result<f64, String> {
        let mut v = self.factor()?;
        while let Some(Tok::Op(op @ ('*' | '/'))) = self.peek().cloned() {
            self.pos += 1;
            let r = self.factor()?;
            v = if op == '*' { v * r } else { v / r };
        }
        Ok(v)
    }
    fn factor(&mut self) -> Result<f64, String> {
        match self.peek().cloned() {
            Some(Tok::Num(x)) => {
                self.pos += 1;
                Ok(x)
            }
            Some(Tok::Ident(name)) => {
                self.pos += 1;
                (self.lookup)(&name)
            }
            Some(Tok::Op('-')) => {
                self.pos += 1;
                Ok(-self.factor()?)
            }
            Some(Tok::LParen) => {
                self.pos += 1;
                let v = self.expr()?;
                if self.peek() != Some(&Tok::RParen) {
                    return Err("missing ')'".into());
                }
                self.pos += 1;
                Ok(v)
            }
            Some(t) => Err(format!("unexpected {t:?}")),
            None => Err("unexpected end of expression".into()),
        }
    }
}

/// Parse and evaluate both sides of a relation: `(lhs, op, rhs)`.
fn sides(
    text: &str,
    lookup: &impl Fn(&str) -> Result<f64, String>,
) -> Result<(f64, &'static str, f64), String> {
    let toks = lex(text)?;
    let split = toks
        .iter()
        .position(|t| matches!(t, Tok::Cmp(_)))
        .ok_or("needs a comparison (<, <=, >, >=, ==, !=)")?;
    let Tok::Cmp(op) = toks[split] else {
        return Err("needs a comparison".into());
    };
    if toks[split + 1..].iter().any(|t| matches!(t, Tok::Cmp(_))) {
        return Err("only one comparison per relation".into());
    }
    let side = |ts: &[Tok]| -> Result<f64, String> {
        let mut p = Parser {
            toks: ts,
            pos: 0,
            lookup,
        };
        let v = p.expr()?;
        if p.pos != ts.len() {
            return Err(format!("unexpected {:?}", ts[p.pos]));
        }
        Ok(v)
    };
    Ok((side(&toks[..split])?, op, side(&toks[split + 1..])?))
}

/// Evaluate a relation; `lookup` resolves metric names. A side that is not
/// finite (a division by zero, an infinite metric) is an error, not a failure.
pub fn eval_relation(
    text: &str,
    lookup: &impl Fn(&str) -> Result<f64, String>,
) -> Result<Check, String> {
    let (lhs, op, rhs) = sides(text, lookup)?;
    if !(lhs.is_finite() && rhs.is_finite()) {
        return Err(format!("a side is not finite ({lhs} {op} {rhs})"));
    }
    // `==` and `!=` compare exactly: they are meant for counts and flags
    // (`faults.recovered == 3`, `theta_bar.failures == 0`), which are exact.
    #[allow(clippy::float_cmp)]
    let holds = match op {
        "<" => lhs < rhs,
        "<=" => lhs <= rhs,
        ">" => lhs > rhs,
        "==" => lhs == rhs,
        "!=" => lhs != rhs,
        _ => lhs >= rhs,
    };
    Ok(Check {
        text: text.to_string(),
        lhs,
        rhs,
        holds,
    })
}

/// Check every expectation. The `*_max` thresholds refer to the distributed
/// track (`theta_bar.rmse <= rmse_max`, ...; `ml_rmse_max` to `ml.rmse`).
/// Each entry is evaluated on its own: an `Err` says why that one cannot be
/// evaluated (unknown metric, syntax error), and the others still are.
pub fn check(
    expect: &ExpectCfg,
    lookup: &impl Fn(&str) -> Result<f64, String>,
) -> Vec<Result<Check, ExpectError>> {
    relations(expect)
        .into_iter()
        .map(|t| {
            eval_relation(&t, lookup).map_err(|reason| ExpectError {
                relation: t,
                reason,
            })
        })
        .collect()
}

/// Every expectation as a relation (`theta_bar.rmse <= 20.0` for the
/// `*_max` thresholds, then the `holds` entries as written).
pub fn relations(expect: &ExpectCfg) -> Vec<String> {
    let mut texts: Vec<String> = Vec::new();
    let thresholds = [
        ("theta_bar.rmse", expect.rmse_max),
        (
            "theta_bar.rmse_after_burn_in",
            expect.rmse_after_burn_in_max,
        ),
        ("theta_bar.median_error", expect.median_error_max),
        ("theta_bar.final_error", expect.final_error_max),
        ("theta_bar.max_disagreement", expect.max_disagreement_max),
        ("ml.rmse", expect.ml_rmse_max),
    ];
    for (name, v) in thresholds {
        if let Some(v) = v {
            texts.push(format!("{name} <= {v:?}"));
        }
    }
    texts.extend(expect.holds.iter().cloned());
    texts
}

/// Check the syntax of every `holds` entry (no metric lookup; the values
/// are only known after a run, so `a / (b - c)` is not judged here).
pub fn validate_syntax(expect: &ExpectCfg) -> Result<(), ExpectError> {
    for t in &expect.holds {
        sides(t, &|_| Ok(1.0)).map_err(|reason| ExpectError {
            relation: t.clone(),
            reason,
        })?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    fn metrics(name: &str) -> Result<f64, String> {
        match name {
            "ogd.ctte" => Ok(2.0),
            "onm.ctte" => Ok(3.0),
            "ls.rmse" => Ok(10.0),
            _ => Err(format!("no metric {name}")),
        }
    }

    #[test]
    fn relations_compare_arithmetic_over_metrics() {
        let c = eval_relation("ogd.ctte < onm.ctte", &metrics).unwrap();
        assert!(c.holds);
        let c = eval_relation("onm.ctte - ogd.ctte >= 0.5 * (1 + 1)", &metrics).unwrap();
        assert!(c.holds);
        assert_relative_eq!(c.lhs, 1.0);
        assert_relative_eq!(c.rhs, 1.0);
        let c = eval_relation("ls.rmse / 4 > 2.6e0", &metrics).unwrap();
        assert!(!c.holds);
        assert!(eval_relation("-ogd.ctte < 0", &metrics).unwrap().holds);
    }

    #[test]
    fn unknown_metrics_and_bad_syntax_are_errors_not_failures() {
        assert!(
            eval_relation("nope.rmse < 1", &metrics)
                .unwrap_err()
                .contains("nope.rmse")
        );
        assert!(
            eval_relation("ogd.ctte", &metrics)
                .unwrap_err()
                .contains("comparison")
        );
        assert!(eval_relation("ogd.ctte < 1 < 2", &metrics).is_err());
        assert!(eval_relation("(ogd.ctte < 1", &metrics).is_err());
        assert!(eval_relation("ogd.ctte < 1 / 0", &metrics).is_err());
    }

    #[test]
    fn equality_is_exact_and_meant_for_counts() {
        let c = eval_relation("ogd.ctte + onm.ctte == 5", &metrics).unwrap();
        assert!(c.holds);
        assert!(
            !eval_relation("ogd.ctte == 2.000001", &metrics)
                .unwrap()
                .holds
        );
        assert!(
            eval_relation("ogd.ctte != onm.ctte", &metrics)
                .unwrap()
                .holds
        );
        assert!(!eval_relation("ls.rmse != 10", &metrics).unwrap().holds);
        let e = eval_relation("ogd.ctte = 2", &metrics).unwrap_err();
        assert!(e.contains("'=='"), "{e}");
        assert!(eval_relation("ogd.ctte == 2 == 2", &metrics).is_err());
        assert!(eval_relation("ogd.ctte ! 2", &metrics).is_err());
    }

    #[test]
    fn one_unknown_metric_does_not_hide_the_other_checks() {
        let e = ExpectCfg {
            holds: vec!["nope.x < 1".into(), "ogd.ctte < onm.ctte".into()],
            ..Default::default()
        };
        let c = check(&e, &metrics);
        assert!(c[0].is_err());
        assert!(c[1].as_ref().unwrap().holds);
    }

    #[test]
    fn syntax_validation_does_not_judge_values_it_cannot_know_yet() {
        let e = ExpectCfg {
            holds: vec!["ogd.ctte / (onm.ctte - ogd.ctte) < 2".into()],
            ..Default::default()
        };
        assert!(validate_syntax(&e).is_ok());
        let bad = ExpectCfg {
            holds: vec!["ogd.ctte <".into()],
            ..Default::default()
        };
        assert!(validate_syntax(&bad).is_err());
    }

    #[test]
    fn thresholds_become_relations_on_the_distributed_track() {
        let e = ExpectCfg {
            rmse_max: Some(5.0),
            holds: vec!["ogd.ctte < onm.ctte".into()],
            ..Default::default()
        };
        let look = |n: &str| match n {
            "theta_bar.rmse" => Ok(4.0),
            other => metrics(other),
        };
        let c: Vec<Check> = check(&e, &look).into_iter().map(Result::unwrap).collect();
        assert_eq!(c.len(), 2);
        assert!(c.iter().all(|c| c.holds));
        assert_eq!(c[0].text, "theta_bar.rmse <= 5.0");
    }
}
