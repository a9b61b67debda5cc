//! `--set KEY=VALUE`: any scenario key overridden by its dotted path
//! (`algorithm.gamma`, `geometry.receivers`, `faults[0].at_s`), the value
//! parsed as TOML and the result validated exactly as the file is.

use super::ScenarioFile;
use crate::model::error::InputError;
use crate::scenario::Scenario;
use crate::scenario::build;
use crate::scenario::cli_error;
use std::path::Path;

/// One `--set KEY=VALUE` override.
#[derive(Debug, Clone, PartialEq)]
pub struct Override {
    /// The dotted key path as written (`algorithm.gamma`, `faults[0].at_s`).
    pub key: String,
    /// The value, parsed as TOML (a bare word that is not TOML is a string).
    pub value: toml::Value,
    /// The flag's text, `KEY=VALUE`, as given (recorded in `run.json`).
    pub text: String,
    /// The flag it came from (`--set`, or `--grid` for a sweep's point).
    pub flag: &'static str,
}

/// One step of a key path: a table key, or an index into an array.
#[derive(Debug, Clone, PartialEq)]
enum Step {
    Key(String),
    Index(usize),
}

/// A `--set` error: names the flag and the key.
fn set_error(flag: &str, text: &str, reason: impl Into<String>) -> InputError {
    cli_error(&format!("{flag} {text}"), reason)
}

impl Override {
    /// Parse `KEY=VALUE`. The value is TOML (`1e-7`, `20`, `[[0,0],[1,1]]`,
    /// `"text"`, `{ model = "gaussian", sigma = 1 }`); a bare word that is
    /// not TOML (`sync`, `gtrs_l0`) is taken as a string.
    pub fn parse(flag: &str) -> Result<Self, InputError> {
        Self::parse_for("--set", flag)
    }

    /// [`Override::parse`] for a value that came from flag `name` (errors
    /// name it: `--grid algorithm.gamma=-1`).
    pub fn parse_for(name: &'static str, flag: &str) -> Result<Self, InputError> {
        let set_error = |text: &str, r: String| set_error(name, text, r);
        let Some((key, value)) = flag.split_once('=') else {
            return Err(set_error(
                flag,
                "expected KEY=VALUE, e.g. algorithm.gamma=1e-7".into(),
            ));
        };
        let key = key.trim();
        parse_path(key).map_err(|r| set_error(flag, r))?;
        if key == "variants" || key.starts_with("variants.") || key.starts_with("variants[") {
            return Err(set_error(
                flag,
                "variants cannot be set: pick one with --variant, then --set its keys".into(),
            ));
        }
        let value = parse_value(value.trim()).map_err(|r| set_error(flag, r))?;
        Ok(Override {
            key: key.to_string(),
            value,
            text: flag.to_string(),
            flag: name,
        })
    }

    /// Apply this override to a scenario table.
    pub fn apply(&self, table: &mut toml::Table) -> Result<(), InputError> {
        let steps = parse_path(&self.key).map_err(|r| set_error(self.flag, &self.text, r))?;
        set_path(table, &steps, self.value.clone()).map_err(|r| set_error(self.flag, &self.text, r))
    }

    /// Blame this override for a validation error `e` of the overridden
    /// file: the error names `--set KEY=VALUE`, then where and why.
    pub fn blame(&self, e: InputError) -> InputError {
        let reason = match e.location {
            Some(l) => format!("{l}: {}", e.reason),
            None => e.reason,
        };
        set_error(self.flag, &self.text, reason)
    }
}

fn parse_value(v: &str) -> Result<toml::Value, String> {
    if v.is_empty() {
        return Err("the value is empty (quote an empty string: KEY='\"\"')".into());
    }
    match toml::from_str::<toml::Table>(&format!("v = {v}")) {
        Ok(mut t) => t.remove("v").ok_or_else(|| "no value".to_string()),
        Err(e) => {
            let bare = v
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || "-_.:/".contains(c));
            if bare {
                Ok(toml::Value::String(v.to_string()))
            } else {
                Err(format!("not a TOML value: {}", e.message().trim()))
            }
        }
    }
}

fn parse_path(key: &str) -> Result<Vec<Step>, String> {
    if key.is_empty() {
        return Err("the key is empty".into());
    }
    let mut steps = Vec::new();
    for part in key.split('.') {
        let (name, mut rest) = match part.find('[') {
            Some(i) => (&part[..i], &part[i..]),
            None => (part, ""),
        };
        let ok = |c: char| c.is_ascii_alphanumeric() || c == '_' || c == '-';
        if name.is_empty() || !name.chars().all(ok) {
            return Err(format!(
                "bad key {key:?}: write dotted names with optional [index], e.g. faults[0].at_s"
            ));
        }
        steps.push(Step::Key(name.to_string()));
        while !rest.is_empty() {
            let close = rest
                .find(']')
                .filter(|_| rest.starts_with('['))
                .ok_or_else(|| format!("bad index in {key:?}"))?;
            let i: usize = rest[1..close]
                .trim()
                .parse()
                .map_err(|_| format!("bad index {:?} in {key:?}", &rest[1..close]))?;
            if i > crate::scenario::MAX_RECEIVERS {
                return Err(format!("index {i} in {key:?} is absurdly large"));
            }
            steps.push(Step::Index(i));
            rest = &rest[close + 1..];
        }
    }
    Ok(steps)
}

/// Set `steps` in `table` to `value`, creating missing tables on the way. An
/// integer that replaces a float stays a float (`gamma=1`).
fn set_path(table: &mut toml::Table, steps: &[Step], value: toml::Value) -> Result<(), String> {
    let mut here = TomlSlot::Table(table);
    let mut done = String::new();
    for (n, step) in steps.iter().enumerate() {
        let last = n + 1 == steps.len();
        let next = match (here, step) {
            (TomlSlot::Table(t), Step::Key(k)) => {
                if last {
                    let v = coerce(t.get(k), value);
                    t.insert(k.clone(), v);
                    return Ok(());
                }
                let entry = t.entry(k.clone()).or_insert_with(|| match steps[n + 1] {
                    Step::Key(_) => toml::Value::Table(toml::Table::new()),
                    Step::Index(_) => toml::Value::Array(Vec::new()),
                });
                let at = if done.is_empty() {
                    k.clone()
                } else {
                    format!("{done}.{k}")
                };
                slot(entry, &at)?
            }
            (TomlSlot::Array(a), Step::Index(i)) => {
                let len = a.len();
                if *i > len || (*i == len && !last) {
                    return Err(format!("{done} has {len} entries, no [{i}]"));
                }
                if last {
                    let v = coerce(a.get(*i), value);
                    if *i == len {
                        a.push(v);
                    } else {
                        a[*i] = v;
                    }
                    return Ok(());
                }
                slot(&mut a[*i], &format!("{done}[{i}]"))?
            }
            (TomlSlot::Table(_), Step::Index(i)) => {
                return Err(format!("{done} is a table, not an array: no [{i}]"));
            }
            (TomlSlot::Array(_), Step::Key(k)) => {
                return Err(format!("{done} is an array: index it, e.g. {done}[0].{k}"));
            }
        };
        match step {
            Step::Key(k) if done.is_empty() => done.push_str(k),
            Step::Key(k) => {
                done.push('.');
                done.push_str(k)
            }
            Step::Index(i) => done.push_str(&format!("[{i}]")),
        }
        here = next;
    }
    Err("the key is empty".into())
}

enum TomlSlot<'a> {
    Table(&'a mut toml::Table),
    Array(&'a mut Vec<toml::Value>),
}

fn slot<'a>(v: &'a mut toml::Value, at: &str) -> Result<TomlSlot<'a>, String> {
    match v {
        toml::Value::Table(t) => Ok(TomlSlot::Table(t)),
        toml::Value::Array(a) => Ok(TomlSlot::Array(a)),
        other => Err(format!(
            "{at} is a {}, not a table or an array",
            other.type_str()
        )),
    }
}

fn coerce(old: Option<&toml::Value>, new: toml::Value) -> toml::Value {
    match (old, new) {
        (Some(toml::Value::Float(_)), toml::Value::Integer(i)) => toml::Value::Float(i as f64),
        (_, v) => v,
    }
}

impl Scenario {
    /// [`Scenario::load_all`] with `--set` overrides applied, after any
    /// variant's own, to the file's keys; the result is validated exactly as
    /// a file is. When the overridden file is invalid but the file alone is
    /// not, the error names the first override that breaks it.
    /// `only`, when not empty, names the variants to build (`--variant`):
    /// the overrides must make those valid, not every variant of the file.
    pub fn load_all_with(
        path: &Path,
        overrides: &[Override],
        only: &[String],
    ) -> Result<Vec<Scenario>, InputError> {
        load_all_with::<2>(path, &read(path)?, overrides, only)
    }
}

fn read(path: &Path) -> Result<String, InputError> {
    crate::scenario::limits::read_scenario_text(path)
}

impl super::AnyScenario {
    /// [`Scenario::load_all_with`] for a file of either dimension (decided
    /// by the file's coordinates; a variant or override keeps it).
    pub fn load_all_with(
        path: &Path,
        overrides: &[Override],
        only: &[String],
    ) -> Result<Vec<super::AnyScenario>, InputError> {
        Self::text_with(path, &read(path)?, overrides, only)
    }

    /// [`AnyScenario::load_all_with`](super::AnyScenario::load_all_with) of
    /// scenario text already read: `path` names it in errors and anchors
    /// the relative file names it holds.
    pub fn text_with(
        path: &Path,
        text: &str,
        overrides: &[Override],
        only: &[String],
    ) -> Result<Vec<super::AnyScenario>, InputError> {
        let file: ScenarioFile =
            toml::from_str(text).map_err(|e| build::toml_error(path, text, &e))?;
        Ok(match super::sections::dimension(path, &file)? {
            3 => load_all_with::<3>(path, text, overrides, only)?
                .into_iter()
                .map(super::AnyScenario::Space)
                .collect(),
            _ => load_all_with::<2>(path, text, overrides, only)?
                .into_iter()
                .map(super::AnyScenario::Plane)
                .collect(),
        })
    }
}

/// [`Scenario::load_all_with`] in `D` dimensions, of the file's `text`.
fn load_all_with<const D: usize>(
    path: &Path,
    text: &str,
    overrides: &[Override],
    only: &[String],
) -> Result<Vec<Scenario<D>>, InputError> {
    if overrides.is_empty() {
        return build::every_from_toml_str::<D>(text, path);
    }
    // The file alone must parse: its own errors keep their line numbers.
    let file: ScenarioFile = toml::from_str(text).map_err(|e| build::toml_error(path, text, &e))?;
    let table: toml::Table = toml::from_str(text).map_err(|e| build::toml_error(path, text, &e))?;
    let names: Vec<&str> = file.variants.iter().map(|v| v.name.trim()).collect();
    if let Some(v) = only.iter().find(|v| !names.contains(&v.as_str())) {
        return Err(cli_error(
            "--variant",
            if names.is_empty() {
                format!("{} has no [[variants]]", path.display())
            } else {
                format!("no variant {v:?} (the file has: {})", names.join(", "))
            },
        ));
    }
    let build =
        |k: usize| Scenario::<D>::all_from_table(&file, &table, path, &overrides[..k], only);
    match build(overrides.len()) {
        Ok(v) => Ok(v),
        Err(e) => {
            if build(0).is_err() {
                return Err(e);
            }
            for k in 1..=overrides.len() {
                if let Err(ek) = build(k) {
                    return Err(overrides[k - 1].blame(ek));
                }
            }
            Err(e)
        }
    }
}

impl<const D: usize> Scenario<D> {
    fn all_from_table(
        file: &ScenarioFile,
        table: &toml::Table,
        path: &Path,
        overrides: &[Override],
        only: &[String],
    ) -> Result<Vec<Scenario<D>>, InputError> {
        let texts: Vec<String> = overrides.iter().map(|o| o.text.clone()).collect();
        let finish = |mut t: toml::Table| -> Result<Scenario<D>, InputError> {
            let before = t.clone();
            for o in overrides {
                o.apply(&mut t)?;
            }
            let f: ScenarioFile =
                toml::Value::Table(t.clone())
                    .try_into()
                    .map_err(|e: toml::de::Error| {
                        let reason = missing_tag_hint(&before, &t, overrides, e.message().trim())
                            .unwrap_or_else(|| e.message().trim().to_string());
                        InputError::file(path, reason)
                    })?;
            let mut sc = Self::from_parsed(f, path)?;
            sc.overrides = texts.clone();
            Ok(sc)
        };
        if file.variants.is_empty() {
            return Ok(vec![finish(table.clone())?]);
        }
        let mut base = table.clone();
        base.remove("variants");
        build::for_each_variant(file, &base, path, only, finish)
    }
}

/// A clearer reason for serde's `missing field `model`` when an override
/// created the table that lacks it (`--set channel.bit_rate=500` on a
/// scenario without `[channel]`): name the key to set and its choices, which
/// serde lists when the tag is given a value no variant has.
fn missing_tag_hint(
    before: &toml::Table,
    after: &toml::Table,
    overrides: &[Override],
    message: &str,
) -> Option<String> {
    let tag = message
        .strip_prefix("missing field `")?
        .split('`')
        .next()?
        .to_string();
    for o in overrides {
        let steps = parse_path(&o.key).ok()?;
        let Some(Step::Key(table)) = steps.first() else {
            continue;
        };
        if steps.len() < 2 || before.contains_key(table) {
            continue;
        }
        let Some(toml::Value::Table(created)) = after.get(table) else {
            continue;
        };
        if created.contains_key(&tag) {
            continue;
        }
        let mut probe = after.clone();
        if let Some(toml::Value::Table(t)) = probe.get_mut(table) {
            t.insert(tag.clone(), toml::Value::String("\u{1}".into()));
        }
        let choices = toml::Value::Table(probe)
            .try_into::<ScenarioFile>()
            .err()
            .and_then(|e| {
                let m = e.message().to_string();
                m.split_once("expected one of ")
                    .or_else(|| m.split_once("expected "))
                    .map(|(_, c)| c.trim().replace('`', ""))
            });
        return Some(match choices {
            Some(c) => format!(
                "the scenario has no [{table}] table, so `{table}.{tag}` must be set too, \
                 to one of {c} (e.g. --set {table}.{tag}=...)"
            ),
            None => {
                format!("the scenario has no [{table}] table, so `{table}.{tag}` must be set too")
            }
        });
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(text: &str) -> toml::Table {
        toml::from_str(text).unwrap()
    }

    #[test]
    fn a_dotted_key_sets_a_nested_value_and_an_integer_replacing_a_float_stays_a_float() {
        let mut t = table("[algorithm]\ngamma = 0.5\n");
        Override::parse("algorithm.gamma=2")
            .unwrap()
            .apply(&mut t)
            .unwrap();
        assert_eq!(t["algorithm"]["gamma"], toml::Value::Float(2.0));
        Override::parse("target.samples=20")
            .unwrap()
            .apply(&mut t)
            .unwrap();
        assert_eq!(t["target"]["samples"], toml::Value::Integer(20));
    }

    #[test]
    fn arrays_tables_and_bare_words_parse_as_toml_values() {
        let mut t = table("[geometry]\nreceivers = [[1.0, 2.0]]\n[algorithm]\nmode = \"async\"\n");
        Override::parse("geometry.receivers=[[0,0],[1,1]]")
            .unwrap()
            .apply(&mut t)
            .unwrap();
        assert_eq!(t["geometry"]["receivers"].as_array().unwrap().len(), 2);
        Override::parse("algorithm.mode=sync")
            .unwrap()
            .apply(&mut t)
            .unwrap();
        assert_eq!(t["algorithm"]["mode"].as_str(), Some("sync"));
        Override::parse("geometry.receivers[1]=[5.0,6.0]")
            .unwrap()
            .apply(&mut t)
            .unwrap();
        assert_eq!(t["geometry"]["receivers"][1][0].as_float(), Some(5.0));
    }

    #[test]
    fn a_bad_set_flag_names_the_flag_and_says_why() {
        for (flag, why) in [
            ("algorithm.gamma", "expected KEY=VALUE"),
            ("=3", "the key is empty"),
            ("a..b=1", "bad key"),
            ("variants[0].name=x", "variants cannot be set"),
            ("x={unclosed=1", "not a TOML value"),
            ("faults[99999999999]=1", "absurdly large"),
        ] {
            let e = Override::parse(flag).unwrap_err();
            let s = e.to_string();
            assert!(s.contains(&format!("--set {flag}")), "{s}");
            assert!(s.contains(why), "{flag}: {s}");
        }
        let mut t = table("[algorithm]\ngamma = 0.5\nfaults = []\n");
        let e = Override::parse("algorithm.gamma.x=1")
            .unwrap()
            .apply(&mut t)
            .unwrap_err();
        assert!(e.to_string().contains("algorithm.gamma is a float"), "{e}");
        let e = Override::parse("algorithm.faults[3]=1")
            .unwrap()
            .apply(&mut t)
            .unwrap_err();
        assert!(e.to_string().contains("has 0 entries"), "{e}");
    }
}
