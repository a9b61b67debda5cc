//! Who may join a run over zenoh: the secrets, the user names, and the fleet
//! key file. The zenoh module turns them into its session configuration (user
//! and password authentication, and access control binding each user to its
//! own key expressions, [`crate::transport::zenoh::config`]).
//!
//! | party | zenoh user | password |
//! |---|---|---|
//! | node `i` | `node-<i>` ([`node_user`]) | fresh for each run ([`Secret::fresh`]), given to the node process in its environment ([`PASSWORD_ENV`]) by the coordinator, or by its agent, which gets it on its own command key |
//! | the agent of host `h` | `agent-<h>` ([`agent_user`]) | issued for the run from the fleet key ([`agent_password`]): the key is a file every host of the fleet holds, readable by its owner only (`sonarnet fleet-key FILE` makes one) |
//!
//! zenoh's handshake proves a password with an HMAC of a fresh nonce, so the
//! password itself never crosses the network; the per-node passwords reach
//! the agents inside the run (in clear over `tcp/` links, encrypted over
//! `quic/` and `tls/` ones). Nothing here is simulation randomness: the
//! secrets come from the operating system (`/dev/urandom`), never from the
//! run seed.

use std::io::{Read, Write};
use std::path::{Path, PathBuf};

/// The environment variable that carries a node process's zenoh password
/// (never its command line, which every user of the host can read).
pub const PASSWORD_ENV: &str = "SONARNET_ZENOH_PASSWORD";

/// Random bytes in a fresh secret (shown as twice as many hex digits).
pub const SECRET_BYTES: usize = 32;

/// The shortest and longest secret accepted from a fleet key file, in
/// characters.
pub const SECRET_LEN: std::ops::RangeInclusive<usize> = 32..=256;

/// The largest fleet key file read, in bytes.
pub const MAX_KEY_FILE_BYTES: u64 = 4096;

/// A password: 32 to 256 characters of `[A-Za-z0-9_-]`. Its `Debug` form
/// hides it.
#[derive(Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(try_from = "String", into = "String")]
pub struct Secret(String);

impl std::fmt::Debug for Secret {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Secret(***)")
    }
}

impl From<Secret> for String {
    fn from(s: Secret) -> String {
        s.0
    }
}

impl TryFrom<String> for Secret {
    type Error = String;
    fn try_from(s: String) -> Result<Secret, String> {
        Secret::parse(&s)
    }
}

impl Secret {
    /// [`SECRET_BYTES`] bytes from the operating system's random source, as
    /// hex.
    pub fn fresh() -> std::io::Result<Secret> {
        let mut b = [0u8; SECRET_BYTES];
        std::fs::File::open("/dev/urandom")?.read_exact(&mut b)?;
        Ok(Secret(b.iter().map(|x| format!("{x:02x}")).collect()))
    }

    /// `text` without surrounding white space, if it is a valid secret; else
    /// why not.
    pub fn parse(text: &str) -> Result<Secret, String> {
        let t = text.trim();
        if !SECRET_LEN.contains(&t.len()) {
            return Err(format!(
                "a key has {} to {} characters, this one {}",
                SECRET_LEN.start(),
                SECRET_LEN.end(),
                t.len()
            ));
        }
        if let Some(c) = t
            .chars()
            .find(|c| !(c.is_ascii_alphanumeric() || *c == '-' || *c == '_'))
        {
            return Err(format!(
                "a key has only the characters A-Z a-z 0-9 - _, this one has {c:?}"
            ));
        }
        Ok(Secret(t.to_string()))
    }

    /// The secret's text, for the one place that hands it to zenoh or to a
    /// child process.
    pub fn expose(&self) -> &str {
        &self.0
    }
}

/// The zenoh user of node `i`.
pub fn node_user(i: u32) -> String {
    format!("node-{i}")
}

/// The zenoh user of the agent of host `host`.
pub fn agent_user(host: &str) -> String {
    format!("agent-{host}")
}

/// The password of the agent of `host` in run `run_id`: the HMAC
/// (SHA3-256, zenoh's own) of `sonarnet agent <run id> <host>` keyed with the
/// fleet key, in hex. The coordinator and the agent each derive it, so the
/// fleet key never serves as a password itself, and a password of one run
/// or host is worth nothing in another.
#[cfg(feature = "zenoh")]
pub fn agent_password(fleet_key: &Secret, run_id: &str, host: &str) -> Result<Secret, String> {
    let mac = zenoh_crypto::hmac::sign(
        fleet_key.expose().as_bytes(),
        format!("sonarnet agent {run_id} {host}").as_bytes(),
    )
    .map_err(|e| format!("deriving the agent's password: {e}"))?;
    Ok(Secret(mac.iter().map(|x| format!("{x:02x}")).collect()))
}

/// A client's credentials: its user and password.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Login {
    /// The zenoh user ([`node_user`], [`agent_user`]).
    pub user: String,
    /// Its password.
    pub password: Secret,
}

impl Login {
    /// Node `i`'s login, with the password its environment carries
    /// ([`PASSWORD_ENV`]).
    pub fn node_from_env(i: u32) -> Result<Login, String> {
        let text = std::env::var(PASSWORD_ENV).map_err(|_| {
            format!(
                "node {i} has no zenoh password: {PASSWORD_ENV} is not set (node processes of a zenoh run are started by the coordinator or by an agent, which set it)"
            )
        })?;
        let password =
            Secret::parse(&text).map_err(|e| format!("{PASSWORD_ENV} is not a password: {e}"))?;
        Ok(Login {
            user: node_user(i),
            password,
        })
    }
}

/// The users the coordinator's router admits for one run: a fresh password
/// per node, and for the agent of each host of the placement the password
/// the fleet key gives it for this run ([`agent_password`]).
#[derive(Debug, Clone)]
pub struct RunCredentials {
    nodes: Vec<Secret>,
    agents: Vec<(String, Secret)>,
}

impl RunCredentials {
    /// Fresh passwords for nodes `0..nodes`, and the passwords of run
    /// `run_id` for the agents of `agent_hosts` from `fleet_key` (which they
    /// need: `None` with hosts is an error naming the flag).
    pub fn fresh(
        nodes: usize,
        agent_hosts: &[&str],
        fleet_key: Option<&Secret>,
        run_id: &str,
    ) -> Result<RunCredentials, String> {
        let agents = match (agent_hosts.is_empty(), fleet_key) {
            (true, _) => Vec::new(),
            #[cfg(feature = "zenoh")]
            (false, Some(k)) => agent_hosts
                .iter()
                .map(|h| Ok((h.to_string(), agent_password(k, run_id, h)?)))
                .collect::<Result<_, String>>()?,
            #[cfg(not(feature = "zenoh"))]
            (false, Some(_)) => {
                let _ = run_id;
                return Err("agents need a sonarnet built with zenoh".into());
            }
            (false, None) => {
                return Err(format!(
                    "nodes placed on the agents of {} need the fleet's key: --fleet-key FILE, the file the agents were given (`sonarnet fleet-key FILE` makes one)",
                    agent_hosts.join(", ")
                ));
            }
        };
        let nodes = (0..nodes)
            .map(|_| Secret::fresh())
            .collect::<Result<_, _>>()
            .map_err(|e| format!("reading /dev/urandom for the nodes' passwords: {e}"))?;
        Ok(RunCredentials { nodes, agents })
    }

    /// Node `i`'s password.
    pub fn node(&self, i: u32) -> Option<&Secret> {
        self.nodes.get(i as usize)
    }

    /// How many nodes have a password.
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// The agents' host names.
    pub fn agent_hosts(&self) -> impl Iterator<Item = &str> {
        self.agents.iter().map(|(h, _)| h.as_str())
    }

    /// The router's user and password dictionary: one `user:password` line
    /// per party.
    pub fn dictionary(&self) -> String {
        let mut s = String::new();
        for (i, p) in self.nodes.iter().enumerate() {
            s.push_str(&format!("{}:{}\n", node_user(i as u32), p.expose()));
        }
        for (h, p) in &self.agents {
            s.push_str(&format!("{}:{}\n", agent_user(h), p.expose()));
        }
        s
    }
}

/// Why a fleet key file cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum FleetKeyError {
    /// It cannot be read (or written).
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// Others than its owner may read it.
    #[error(
        "{}: the fleet key is readable by others (mode {mode:o}); `chmod 600 {}` makes it the owner's only",
        path.display(),
        path.display()
    )]
    Open {
        /// The file.
        path: PathBuf,
        /// Its permission bits.
        mode: u32,
    },
    /// It is not a key.
    #[error("{}: {reason}", path.display())]
    Form {
        /// The file.
        path: PathBuf,
        /// Why.
        reason: String,
    },
    /// `sonarnet fleet-key` does not overwrite a file.
    #[error("{}: exists; a fleet key file is never overwritten (remove it first)", path.display())]
    Exists {
        /// The file.
        path: PathBuf,
    },
}

/// Reads the fleet key in `path`: a file of its owner only (no permission for
/// group or others), at most [`MAX_KEY_FILE_BYTES`] bytes, holding one
/// [`Secret`].
pub fn read_fleet_key(path: &Path) -> Result<Secret, FleetKeyError> {
    use std::os::unix::fs::PermissionsExt;
    let io = |source| FleetKeyError::Io {
        path: path.to_path_buf(),
        source,
    };
    let file = std::fs::File::open(path).map_err(io)?;
    let meta = file.metadata().map_err(io)?;
    let mode = meta.permissions().mode() & 0o777;
    if mode & 0o077 != 0 {
        return Err(FleetKeyError::Open {
            path: path.to_path_buf(),
            mode,
        });
    }
    let mut text = String::new();
    file.take(MAX_KEY_FILE_BYTES + 1)
        .read_to_string(&mut text)
        .map_err(io)?;
    if text.len() as u64 > MAX_KEY_FILE_BYTES {
        return Err(FleetKeyError::Form {
            path: path.to_path_buf(),
            reason: format!("larger than {MAX_KEY_FILE_BYTES} bytes: not a fleet key"),
        });
    }
    Secret::parse(&text).map_err(|reason| FleetKeyError::Form {
        path: path.to_path_buf(),
        reason,
    })
}

/// Writes a fresh fleet key to `path`, a new file readable by its owner only
/// (mode 0600); an existing file is left alone.
pub fn write_fleet_key(path: &Path) -> Result<Secret, FleetKeyError> {
    use std::os::unix::fs::OpenOptionsExt;
    let io = |source| FleetKeyError::Io {
        path: path.to_path_buf(),
        source,
    };
    let key = Secret::fresh().map_err(io)?;
    let mut f = std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .mode(0o600)
        .open(path)
        .map_err(|e| match e.kind() {
            std::io::ErrorKind::AlreadyExists => FleetKeyError::Exists {
                path: path.to_path_buf(),
            },
            _ => io(e),
        })?;
    writeln!(f, "{}", key.expose()).map_err(io)?;
    Ok(key)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::os::unix::fs::PermissionsExt;

    #[test]
    fn fresh_secrets_are_64_hex_digits_and_differ() {
        let a = Secret::fresh().unwrap();
        let b = Secret::fresh().unwrap();
        assert_eq!(a.expose().len(), 2 * SECRET_BYTES);
        assert!(a.expose().chars().all(|c| c.is_ascii_hexdigit()));
        assert_ne!(a, b);
        assert_eq!(format!("{a:?}"), "Secret(***)");
    }

    #[test]
    fn a_secret_is_refused_when_short_long_or_with_a_colon_or_space() {
        assert!(Secret::parse(&"a".repeat(31)).is_err());
        assert!(Secret::parse(&"a".repeat(32)).is_ok());
        assert!(Secret::parse(&format!("  {}\n", "a".repeat(40))).is_ok());
        assert!(Secret::parse(&"a".repeat(257)).is_err());
        let e = Secret::parse(&format!("{}:x", "a".repeat(40))).unwrap_err();
        assert!(e.contains("':'"), "{e}");
        assert!(Secret::parse(&format!("{} {}", "a".repeat(20), "b".repeat(20))).is_err());
    }

    #[test]
    fn a_written_fleet_key_is_the_owners_only_reads_back_and_is_never_overwritten() {
        let dir = std::env::temp_dir().join(format!("sonarnet-fk-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("fleet.key");
        let k = write_fleet_key(&path).unwrap();
        let mode = std::fs::metadata(&path).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode, 0o600);
        assert_eq!(read_fleet_key(&path).unwrap(), k);
        let e = write_fleet_key(&path).unwrap_err();
        assert!(matches!(e, FleetKeyError::Exists { .. }), "{e}");
        assert_eq!(read_fleet_key(&path).unwrap(), k);
        std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o644)).unwrap();
        let e = read_fleet_key(&path).unwrap_err().to_string();
        assert!(
            e.contains("readable by others (mode 644)") && e.contains("chmod 600"),
            "{e}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_fleet_key_file_that_is_too_large_or_not_a_key_is_named() {
        use std::os::unix::fs::OpenOptionsExt;
        let dir = std::env::temp_dir().join(format!("sonarnet-fk2-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        for (name, text, says) in [
            ("big.key", "a".repeat(5000), "larger than 4096 bytes"),
            ("short.key", "abc".into(), "this one 3"),
        ] {
            let path = dir.join(name);
            let mut f = std::fs::OpenOptions::new()
                .write(true)
                .create_new(true)
                .mode(0o600)
                .open(&path)
                .unwrap();
            f.write_all(text.as_bytes()).unwrap();
            let e = read_fleet_key(&path).unwrap_err().to_string();
            assert!(e.contains(name) && e.contains(says), "{e}");
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn run_credentials_give_every_node_and_agent_one_dictionary_line() {
        let key = Secret::parse(&"k".repeat(40)).unwrap();
        let c = RunCredentials::fresh(3, &["a", "b"], Some(&key), "r1").unwrap();
        let d = c.dictionary();
        assert_eq!(d.lines().count(), 5);
        assert!(d.contains(&format!("node-2:{}\n", c.node(2).unwrap().expose())));
        assert!(!d.contains(&"k".repeat(40)), "the fleet key is no password");
        #[cfg(feature = "zenoh")]
        {
            let b = agent_password(&key, "r1", "b").unwrap();
            assert!(d.contains(&format!("agent-b:{}\n", b.expose())));
            assert_eq!(b.expose().len(), 64);
            assert_ne!(b, agent_password(&key, "r2", "b").unwrap());
            assert_ne!(b, agent_password(&key, "r1", "a").unwrap());
        }
        assert_ne!(c.node(0), c.node(1));
        assert!(c.node(3).is_none());
        let e = RunCredentials::fresh(3, &["a"], None, "r1").unwrap_err();
        assert!(
            e.contains("--fleet-key") && e.contains("agents of a"),
            "{e}"
        );
        assert!(RunCredentials::fresh(3, &[], None, "r1").is_ok());
    }

    #[test]
    fn a_node_login_needs_its_password_in_the_environment() {
        // The variable is not set in the test process.
        if std::env::var(PASSWORD_ENV).is_err() {
            let e = Login::node_from_env(4).unwrap_err();
            assert!(e.contains(PASSWORD_ENV) && e.contains("node 4"), "{e}");
        }
    }
}
