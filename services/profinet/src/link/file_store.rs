//! The device's permanent values in small text files, each replaced atomically: the
//! station parameters DCP sets ([`FileStore`]) and the I&M1..4 records a controller
//! writes ([`ImFile`]).

use std::io::{self, Write as _};
use std::path::{Path, PathBuf};

use crate::cm::im::{ImRecordError, ImRecords};
use crate::dcp::record::{self, PermanentRecordError};
use crate::dcp::station::{PermanentStore, StationParameters};

/// Reading or writing the file failed.
#[derive(Debug, thiserror::Error)]
pub enum FileStoreError {
    /// The file system refused.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        source: io::Error,
    },
    /// The file's content is damaged.
    #[error("{path}: {source}")]
    Record {
        /// The file.
        path: PathBuf,
        /// What is wrong with it.
        source: PermanentRecordError,
    },
    /// The I&M file's content is damaged.
    #[error("{path}: {source}")]
    Im {
        /// The file.
        path: PathBuf,
        /// What is wrong with it.
        source: ImRecordError,
    },
}

/// Writes `text` to `path` beside it and renames it: a crash leaves the old or the new
/// file, never half.
fn write_atomically(path: &Path, text: &str) -> Result<(), FileStoreError> {
    let mut temporary = path.to_path_buf().into_os_string();
    temporary.push(".tmp");
    let temporary = PathBuf::from(temporary);
    let write = || -> io::Result<()> {
        let mut file = std::fs::File::create(&temporary)?;
        file.write_all(text.as_bytes())?;
        file.sync_all()?;
        std::fs::rename(&temporary, path)
    };
    write().map_err(|source| FileStoreError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// The I&M1..4 records in the file at `path` (its folder must exist).
#[derive(Debug, Clone)]
pub struct ImFile {
    path: PathBuf,
}

impl ImFile {
    /// The records in the file `path`.
    pub fn new(path: impl Into<PathBuf>) -> Self {
        Self { path: path.into() }
    }

    /// The stored records; blank ones when there is no file yet.
    pub fn load(&self) -> Result<ImRecords, FileStoreError> {
        match std::fs::read_to_string(&self.path) {
            Ok(text) => ImRecords::decode(&text).map_err(|source| FileStoreError::Im {
                path: self.path.clone(),
                source,
            }),
            Err(error) if error.kind() == io::ErrorKind::NotFound => Ok(ImRecords::default()),
            Err(source) => Err(FileStoreError::Io {
                path: self.path.clone(),
                source,
            }),
        }
    }

    /// Stores `records`, replacing the file.
    pub fn save(&self, records: &ImRecords) -> Result<(), FileStoreError> {
        write_atomically(&self.path, &records.encode())
    }
}

/// The permanent store in the file at `path` (its folder must exist).
#[derive(Debug, Clone)]
pub struct FileStore {
    path: PathBuf,
}

impl FileStore {
    /// A store in the file `path`.
    pub fn new(path: impl Into<PathBuf>) -> Self {
        Self { path: path.into() }
    }

    /// The file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    fn io(&self, source: io::Error) -> FileStoreError {
        FileStoreError::Io {
            path: self.path.clone(),
            source,
        }
    }
}

impl PermanentStore for FileStore {
    type Error = FileStoreError;

    fn load(&mut self) -> Result<Option<StationParameters>, Self::Error> {
        match std::fs::read_to_string(&self.path) {
            Ok(text) => record::decode(&text)
                .map(Some)
                .map_err(|source| FileStoreError::Record {
                    path: self.path.clone(),
                    source,
                }),
            Err(error) if error.kind() == io::ErrorKind::NotFound => Ok(None),
            Err(error) => Err(self.io(error)),
        }
    }

    fn save(&mut self, parameters: &StationParameters) -> Result<(), Self::Error> {
        write_atomically(&self.path, &record::encode(parameters))
    }

    fn erase(&mut self) -> Result<(), Self::Error> {
        match std::fs::remove_file(&self.path) {
            Err(error) if error.kind() != io::ErrorKind::NotFound => Err(self.io(error)),
            _ => Ok(()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dcp::station::{IpParameter, NameOfStation};

    fn folder(test: &str) -> PathBuf {
        let dir =
            std::env::temp_dir().join(format!("profinet-file-store-{}-{test}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    #[test]
    fn saved_parameters_load_back_and_erase_forgets_them() {
        let dir = folder("roundtrip");
        let mut store = FileStore::new(dir.join("station"));
        assert!(store.load().unwrap().is_none());
        let parameters = StationParameters {
            name_of_station: NameOfStation::new(b"rc-robot").unwrap(),
            ip: IpParameter::UNSET,
        };
        store.save(&parameters).unwrap();
        assert_eq!(store.load().unwrap(), Some(parameters));
        store.erase().unwrap();
        assert!(store.load().unwrap().is_none());
        store.erase().unwrap();
        std::fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn a_damaged_file_is_reported_with_its_path() {
        let dir = folder("damaged");
        let path = dir.join("station");
        std::fs::write(&path, "name_of_station = rc-robot\n").unwrap();
        let error = FileStore::new(&path).load().unwrap_err();
        assert!(error.to_string().contains("missing key `ip`"), "{error}");
        assert!(error.to_string().contains("station"), "{error}");
        std::fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn i_and_m_records_are_saved_and_loaded_back() {
        let dir = folder("im");
        let file = ImFile::new(dir.join("im"));
        assert_eq!(file.load().unwrap(), ImRecords::default());
        let mut records = ImRecords::default();
        let mut im2 = records.read(crate::cm::im::INDEX_IM2).unwrap();
        im2[6..].copy_from_slice(b"2026-11-22 08:15");
        records
            .write(crate::cm::im::INDEX_IM2, &im2)
            .unwrap()
            .unwrap();
        file.save(&records).unwrap();
        assert_eq!(file.load().unwrap(), records);
        std::fs::write(dir.join("im"), "im2 = 00\n").unwrap();
        assert!(matches!(file.load(), Err(FileStoreError::Im { .. })));
        std::fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn an_unwritable_folder_is_an_io_error() {
        let mut store = FileStore::new("/nonexistent-folder/station");
        let parameters = StationParameters {
            name_of_station: NameOfStation::default(),
            ip: IpParameter::UNSET,
        };
        assert!(matches!(
            store.save(&parameters),
            Err(FileStoreError::Io { .. })
        ));
    }
}
