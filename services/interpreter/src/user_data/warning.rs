//! What went wrong with the user data at start-up or while saving it: each becomes a warning
//! in ReadMessages; the controller keeps running with the data it has.

use std::path::PathBuf;

use super::model::DataSet;

/// A problem with the persistent user data that did not stop the controller.
#[derive(Debug, thiserror::Error)]
pub enum UserDataWarning {
    /// The file could not be parsed or checked: factory values are in use.
    #[error("user data file {file} is corrupt ({reason}): factory values in use, {}", kept_text(.kept))]
    Corrupt {
        file: PathBuf,
        reason: String,
        /// Where the bad file was moved to, if it could be moved.
        kept: Option<PathBuf>,
    },
    /// The file exists but could not be read: factory values are in use.
    #[error("user data file {file} cannot be read ({source}): factory values in use, {}", kept_text(.kept))]
    Unreadable {
        file: PathBuf,
        source: std::io::Error,
        kept: Option<PathBuf>,
    },
    /// Entries of the file broke a rule of this robot (mass above its payload, SW limits of
    /// another robot or outside its mechanical limits, ...) and were reset to factory values
    /// with DataChanged set.
    #[error("user data reset to factory values for this robot: {}", set_names(.sets))]
    Adjusted { sets: Vec<DataSet> },
    /// The robot's payload is not known: loads are limited to an assumed value.
    #[error("rated payload of robot \"{robot}\" unknown: loads limited to {assumed_kg} kg")]
    PayloadUnknown { robot: String, assumed_kg: f64 },
    /// Saving failed: the data in use is newer than the file.
    #[error("user data not saved: {0}")]
    NotSaved(#[from] PersistError),
}

/// Writing the user data file failed.
#[derive(Debug, thiserror::Error)]
pub enum PersistError {
    #[error("cannot encode the user data: {0}")]
    Encode(#[from] toml::ser::Error),
    #[error("cannot write {file}: {source}")]
    Write {
        file: PathBuf,
        source: std::io::Error,
    },
}

fn kept_text(kept: &Option<PathBuf>) -> String {
    match kept {
        Some(p) => format!("the file was kept as {}", p.display()),
        None => "the file could not be moved aside and will be overwritten".into(),
    }
}

fn set_names(sets: &[DataSet]) -> String {
    sets.iter().map(|s| s.name()).collect::<Vec<_>>().join(", ")
}
