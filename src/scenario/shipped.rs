//! The scenarios of `scenarios/`, built into the binary: `sonarnet list`
//! works from any directory, and `sonarnet new FILE --from NAME` copies one
//! out to edit. A test checks that this list is exactly the directory.

use super::AnyScenario;
use crate::model::error::InputError;
use std::path::{Path, PathBuf};

/// (name, TOML text) of every shipped scenario, by name.
pub const SHIPPED: &[(&str, &str)] = &[
    (
        "gholami-3d",
        include_str!("../../scenarios/gholami-3d.toml"),
    ),
    (
        "gholami-gaussian",
        include_str!("../../scenarios/gholami-gaussian.toml"),
    ),
    (
        "gholami-los",
        include_str!("../../scenarios/gholami-los.toml"),
    ),
    (
        "gholami-moving-target",
        include_str!("../../scenarios/gholami-moving-target.toml"),
    ),
    (
        "gholami-nlos",
        include_str!("../../scenarios/gholami-nlos.toml"),
    ),
    (
        "mourya2017-spiral",
        include_str!("../../scenarios/mourya2017-spiral.toml"),
    ),
    (
        "mourya2017-spiral-3d",
        include_str!("../../scenarios/mourya2017-spiral-3d.toml"),
    ),
    (
        "mourya2017-spiral-3d-acoustic",
        include_str!("../../scenarios/mourya2017-spiral-3d-acoustic.toml"),
    ),
    (
        "mourya2017-spiral-acoustic",
        include_str!("../../scenarios/mourya2017-spiral-acoustic.toml"),
    ),
    (
        "mourya2017-spiral-certified",
        include_str!("../../scenarios/mourya2017-spiral-certified.toml"),
    ),
    (
        "mourya2017-spiral-eq5",
        include_str!("../../scenarios/mourya2017-spiral-eq5.toml"),
    ),
    (
        "mourya2017-spiral-faults",
        include_str!("../../scenarios/mourya2017-spiral-faults.toml"),
    ),
    (
        "mourya2017-spiral-nlos",
        include_str!("../../scenarios/mourya2017-spiral-nlos.toml"),
    ),
    (
        "pun-so-large-noise",
        include_str!("../../scenarios/pun-so-large-noise.toml"),
    ),
    (
        "pun-so-regret",
        include_str!("../../scenarios/pun-so-regret.toml"),
    ),
    (
        "pun-so-small-noise",
        include_str!("../../scenarios/pun-so-small-noise.toml"),
    ),
    (
        "rgg16-waypoints",
        include_str!("../../scenarios/rgg16-waypoints.toml"),
    ),
    ("shi-gmm", include_str!("../../scenarios/shi-gmm.toml")),
    (
        "shi-laplacian",
        include_str!("../../scenarios/shi-laplacian.toml"),
    ),
    (
        "shi-nlos-exponential",
        include_str!("../../scenarios/shi-nlos-exponential.toml"),
    ),
    (
        "sonobuoy-drift-3d",
        include_str!("../../scenarios/sonobuoy-drift-3d.toml"),
    ),
];

/// The text of the shipped scenario `name` (with or without `.toml`).
pub fn text(name: &str) -> Option<&'static str> {
    let name = name.strip_suffix(".toml").unwrap_or(name);
    SHIPPED.iter().find(|(n, _)| *n == name).map(|(_, t)| *t)
}

/// The path a shipped scenario is reported under: `scenarios/NAME.toml`.
pub fn path(name: &str) -> PathBuf {
    Path::new("scenarios").join(format!("{name}.toml"))
}

/// Every variant of the shipped scenario `name`, validated, in its
/// dimension.
pub fn load(name: &str) -> Result<Vec<AnyScenario>, InputError> {
    let text = text(name).ok_or_else(|| {
        InputError::file(
            Path::new(name),
            format!(
                "no shipped scenario of that name (sonarnet list names them: {})",
                names().join(", ")
            ),
        )
    })?;
    AnyScenario::all_from_toml_str(text, &path(name))
}

/// The names of the shipped scenarios.
pub fn names() -> Vec<&'static str> {
    SHIPPED.iter().map(|(n, _)| *n).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_built_in_list_is_exactly_the_scenarios_directory() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios");
        let mut on_disk: Vec<String> = std::fs::read_dir(&dir)
            .expect("scenarios/")
            .flatten()
            .map(|e| e.path())
            .filter(|p| p.extension().is_some_and(|x| x == "toml"))
            .filter_map(|p| Some(p.file_stem()?.to_string_lossy().into_owned()))
            .collect();
        on_disk.sort();
        assert_eq!(on_disk, names(), "add or remove the file in SHIPPED");
        for (n, t) in SHIPPED {
            let disk = std::fs::read_to_string(dir.join(format!("{n}.toml"))).expect("read");
            assert_eq!(&disk, t, "{n}");
        }
    }

    #[test]
    fn every_shipped_scenario_validates_from_its_built_in_text() {
        for n in names() {
            let all = load(n).unwrap_or_else(|e| panic!("{n}: {e}"));
            assert!(!all.is_empty());
        }
        assert!(load("no-such-scenario").is_err());
        assert!(text("mourya2017-spiral.toml").is_some());
    }
}
