//! The benchmark's own controller configuration: the user's (or the embedded default) with a
//! private instance name, a free TCP port and its data in a temporary folder, so that the
//! benchmark never meets a running controller or its user data.

use std::net::TcpListener;
use std::path::{Path, PathBuf};

use anyhow::Context;
use shared_types::config::{Config, EMBEDDED_DEFAULT};
use toml::{Table, Value};

/// A configuration file cannot be given a private instance.
#[derive(Debug, thiserror::Error)]
pub enum PrivateConfigError {
    #[error("cannot parse the configuration: {0}")]
    Parse(#[from] toml::de::Error),
    #[error("the configuration has no [{0}] table")]
    MissingTable(&'static str),
    #[error("cannot write the configuration: {0}")]
    Write(#[from] toml::ser::Error),
}

/// `text` (a `default.toml`) with `instance`, `fieldbus.listen` and `interpreter.data_dir`
/// replaced.
pub fn private_config_text(
    text: &str,
    instance: &str,
    listen: &str,
    data_dir: &Path,
) -> Result<String, PrivateConfigError> {
    let mut table: Table = text.parse()?;
    table.insert("instance".into(), Value::String(instance.into()));
    let mut set = |section: &'static str, key: &str, value: String| {
        table
            .get_mut(section)
            .and_then(Value::as_table_mut)
            .ok_or(PrivateConfigError::MissingTable(section))
            .map(|t| t.insert(key.into(), Value::String(value)))
    };
    set("fieldbus", "listen", listen.into())?;
    set("interpreter", "data_dir", data_dir.display().to_string())?;
    Ok(toml::to_string(&table)?)
}

/// A private configuration in a temporary folder, removed when dropped unless kept.
pub struct PrivateController {
    pub config: Config,
    dir: PathBuf,
    keep: bool,
}

impl PrivateController {
    /// Writes `base`'s configuration with instance `instance` and a free port.
    pub fn create(base: &Config, instance: &str) -> anyhow::Result<Self> {
        let dir = std::env::temp_dir().join(format!("rc-{instance}"));
        std::fs::create_dir_all(&dir)
            .with_context(|| format!("cannot create {}", dir.display()))?;
        let mut this = Self {
            config: base.clone(),
            dir,
            keep: false,
        };
        let text = match &base.path {
            Some(path) => std::fs::read_to_string(path)
                .with_context(|| format!("cannot read {}", path.display()))?,
            None => EMBEDDED_DEFAULT.to_string(),
        };
        let port = TcpListener::bind("127.0.0.1:0")
            .and_then(|l| l.local_addr())
            .context("no free TCP port on 127.0.0.1")?
            .port();
        let text = private_config_text(
            &text,
            instance,
            &format!("127.0.0.1:{port}"),
            &this.dir.join("data"),
        )
        .with_context(|| base.source.clone())?;
        // Robot files beside the user's configuration stay reachable from the copy.
        if let Some(robots) = base
            .path
            .as_deref()
            .and_then(Path::parent)
            .map(|d| d.join("robots"))
            && robots.is_dir()
        {
            let link = this.dir.join("robots");
            let _ = std::fs::remove_file(&link);
            std::os::unix::fs::symlink(&robots, &link)
                .with_context(|| format!("cannot link {}", robots.display()))?;
        }
        let path = this.dir.join("default.toml");
        std::fs::write(&path, text).with_context(|| format!("cannot write {}", path.display()))?;
        this.config = Config::load(Some(&path))?;
        Ok(this)
    }

    /// Where the controller's log goes.
    pub fn log_path(&self) -> PathBuf {
        self.dir.join("rc.log")
    }

    /// Keeps the folder (with the controller's log) after the run.
    pub fn keep(&mut self) {
        self.keep = true;
    }
}

impl Drop for PrivateController {
    fn drop(&mut self) {
        if !self.keep {
            // A temporary folder; if it cannot be removed, the system's clean-up will.
            let _ = std::fs::remove_dir_all(&self.dir);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_private_copy_loads_with_the_new_values() {
        let dir = std::env::temp_dir().join(format!("rc-bench-config-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let text = private_config_text(
            EMBEDDED_DEFAULT,
            "bench42",
            "127.0.0.1:4711",
            &dir.join("d"),
        )
        .unwrap();
        let path = dir.join("default.toml");
        std::fs::write(&path, text).unwrap();
        let config = Config::load(Some(&path)).unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
        let reference = Config::load(None).unwrap();
        assert_eq!(config.main.instance, "bench42");
        assert_eq!(config.main.fieldbus.listen, "127.0.0.1:4711");
        assert_eq!(
            config.main.interpreter.data_dir,
            dir.join("d").display().to_string()
        );
        assert_eq!(config.robot.name, reference.robot.name);
        assert_eq!(config.main.servo.period_us, reference.main.servo.period_us);
    }

    #[test]
    fn a_configuration_without_fieldbus_is_refused() {
        let e = private_config_text("instance = \"x\"", "b", "127.0.0.1:1", Path::new("/d"))
            .unwrap_err();
        assert!(
            matches!(e, PrivateConfigError::MissingTable("fieldbus")),
            "{e}"
        );
    }
}
