//! The user data on disk: one TOML file in the data folder, replaced atomically (temporary
//! file, fsync, rename, fsync of the folder), so that a crash leaves either the old or the new
//! file. A [`Saver`] thread does the writing, so the interpreter loop never waits for the disk.

use std::fs::{self, File};
use std::io::{ErrorKind, Write};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Condvar, Mutex, PoisonError};
use std::thread::JoinHandle;

use serde::{Deserialize, Serialize};
use shared_types::config::RobotConfig;

use super::model::Stored;
use super::robot::RobotBounds;
use super::store::UserData;
use super::warning::{PersistError, UserDataWarning};

/// Name of the file in the data folder.
pub const FILE_NAME: &str = "user_data.toml";
/// The file being written; a leftover one (a crash while saving) is never read.
const TEMP_NAME: &str = "user_data.toml.tmp";
/// Version of the file layout; another version is treated as corrupt.
const FORMAT: u32 = 1;
/// Corrupt files are kept as `user_data.toml.corrupt-N` with the first free N up to this.
const MAX_KEPT: u32 = 99;

/// The file's content.
#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct UserDataFile {
    format: u32,
    /// The robot the data was saved for.
    robot: String,
    data: Stored,
}

impl UserData {
    /// The user data saved in `dir` for `robot`, or factory values if there is none. A file
    /// that cannot be read or parsed is moved aside and factory values (with DataChanged set)
    /// are used; what went wrong comes back as warnings.
    pub fn load(dir: &Path, robot: &RobotConfig) -> (UserData, Vec<UserDataWarning>) {
        let (bounds, payload_warning) = RobotBounds::of(robot);
        let mut warnings: Vec<UserDataWarning> = payload_warning.into_iter().collect();
        let file = dir.join(FILE_NAME);
        let text = match fs::read(&file) {
            Ok(bytes) => bytes,
            Err(e) if e.kind() == ErrorKind::NotFound => {
                return (UserData::factory(bounds), warnings);
            }
            Err(source) => {
                let kept = set_aside(&file);
                warnings.push(UserDataWarning::Unreadable { file, source, kept });
                return (UserData::restored(bounds), warnings);
            }
        };
        let parsed = String::from_utf8(text)
            .map_err(|e| e.to_string())
            .and_then(|t| toml::from_str::<UserDataFile>(&t).map_err(|e| e.to_string()))
            .and_then(|f| {
                if f.format == FORMAT {
                    Ok(f)
                } else {
                    Err(format!("format {} (expected {FORMAT})", f.format))
                }
            });
        match parsed {
            Ok(f) => {
                let (data, adjusted) = UserData::from_stored(f.data, &f.robot, bounds);
                if !adjusted.is_empty() {
                    warnings.push(UserDataWarning::Adjusted { sets: adjusted });
                }
                (data, warnings)
            }
            Err(reason) => {
                let kept = set_aside(&file);
                warnings.push(UserDataWarning::Corrupt {
                    file,
                    reason: reason.trim_end().to_string(),
                    kept,
                });
                (UserData::restored(bounds), warnings)
            }
        }
    }
}

/// Moves a bad file out of the way; returns where it went.
fn set_aside(file: &Path) -> Option<PathBuf> {
    let name = file.file_name()?.to_string_lossy().into_owned();
    let target = (1..=MAX_KEPT)
        .map(|n| file.with_file_name(format!("{name}.corrupt-{n}")))
        .find(|p| !p.exists())?;
    fs::rename(file, &target).ok().map(|()| target)
}

/// Writes `data` of robot `robot` to `dir` atomically, creating the folder if needed.
pub fn save(dir: &Path, robot: &str, data: &Stored) -> Result<(), PersistError> {
    let text = toml::to_string(&UserDataFile {
        format: FORMAT,
        robot: robot.to_string(),
        data: *data,
    })?;
    let io = |file: &Path| {
        let file = file.to_path_buf();
        move |source| PersistError::Write { file, source }
    };
    let temp = dir.join(TEMP_NAME);
    let target = dir.join(FILE_NAME);
    fs::create_dir_all(dir).map_err(io(dir))?;
    let mut f = File::create(&temp).map_err(io(&temp))?;
    f.write_all(text.as_bytes()).map_err(io(&temp))?;
    f.sync_all().map_err(io(&temp))?;
    drop(f);
    fs::rename(&temp, &target).map_err(io(&target))?;
    // The rename is durable only once the folder is on disk too.
    File::open(dir).and_then(|d| d.sync_all()).map_err(io(dir))
}

/// What the interpreter loop and the saver thread share.
#[derive(Debug, Default)]
struct Mailbox {
    /// The newest data not yet written (an older one is simply replaced).
    pending: Option<Stored>,
    /// The last save failure, until it is taken.
    failure: Option<PersistError>,
    stop: bool,
}

/// A thread that saves the user data: [`Saver::submit`] hands over the newest data without
/// waiting or allocating; dropping the saver writes what is pending and ends the thread.
#[derive(Debug)]
pub struct Saver {
    shared: Arc<(Mutex<Mailbox>, Condvar)>,
    thread: Option<JoinHandle<()>>,
}

impl Saver {
    /// Starts the thread that saves to `dir` for robot `robot`.
    pub fn spawn(dir: PathBuf, robot: String) -> std::io::Result<Saver> {
        let shared = Arc::new((Mutex::new(Mailbox::default()), Condvar::new()));
        let theirs = Arc::clone(&shared);
        let thread = std::thread::Builder::new()
            .name("user-data-saver".into())
            .spawn(move || save_loop(&theirs, &dir, &robot))?;
        Ok(Saver {
            shared,
            thread: Some(thread),
        })
    }

    /// Queues `data` to be saved; replaces data not saved yet.
    pub fn submit(&self, data: Stored) {
        let (mailbox, wakeup) = &*self.shared;
        lock(mailbox).pending = Some(data);
        wakeup.notify_one();
    }

    /// The last save failure since the previous call, if any.
    pub fn take_failure(&self) -> Option<PersistError> {
        lock(&self.shared.0).failure.take()
    }
}

impl Drop for Saver {
    fn drop(&mut self) {
        let (mailbox, wakeup) = &*self.shared;
        lock(mailbox).stop = true;
        wakeup.notify_one();
        if let Some(t) = self.thread.take()
            && t.join().is_err()
        {
            tracing::error!("user data saver thread panicked: last changes may be unsaved");
        }
    }
}

/// A poisoned lock only means the other side panicked; the mailbox itself stays consistent.
fn lock(m: &Mutex<Mailbox>) -> std::sync::MutexGuard<'_, Mailbox> {
    m.lock().unwrap_or_else(PoisonError::into_inner)
}

fn save_loop(shared: &(Mutex<Mailbox>, Condvar), dir: &Path, robot: &str) {
    let (mailbox, wakeup) = shared;
    loop {
        let (data, stop) = {
            let mut m = lock(mailbox);
            while m.pending.is_none() && !m.stop {
                m = wakeup.wait(m).unwrap_or_else(PoisonError::into_inner);
            }
            (m.pending.take(), m.stop)
        };
        if let Some(data) = data {
            match save(dir, robot, &data) {
                Ok(()) => tracing::debug!(dir = %dir.display(), "user data saved"),
                Err(e) => {
                    tracing::warn!(error = %e, "user data not saved");
                    lock(mailbox).failure = Some(e);
                }
            }
        }
        if stop {
            return;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::user_data::model::{DataSet, Entry, LoadData, Timestamp, ToolData};
    use shared_types::config::Config;

    /// A fresh, empty folder for one test.
    fn folder(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("rc-user-data-{name}-{}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        dir
    }

    fn robot() -> RobotConfig {
        Config::load(None).unwrap().robot
    }

    fn tool(x: f32) -> ToolData {
        ToolData {
            pose: [x, 2.0, 3.0, 0.1, -0.2, 90.0],
            id: 7,
            load_no: 2,
            external_tcp: false,
        }
    }

    const STAMP: Timestamp = Timestamp {
        date: 0x2B67,
        time_of_day_ms: 3_600_000,
    };

    /// Saves factory data with tool 1 written, as the controller would.
    fn saved(dir: &Path, robot: &RobotConfig) -> UserData {
        let (mut data, _) = UserData::load(dir, robot);
        data.write_tool(1, STAMP, tool(5.0), false).unwrap();
        save(dir, &robot.name, &data.take_unsaved().unwrap()).unwrap();
        data
    }

    #[test]
    fn no_file_means_factory_values_without_warning() {
        let dir = folder("none");
        let (mut data, warnings) = UserData::load(&dir, &robot());
        assert!(warnings.is_empty(), "{warnings:?}");
        assert_eq!(data.change_index(DataSet::Tool), 0);
        assert!(!data.data_changed(DataSet::SwLimits));
        assert_eq!(data.take_unsaved(), None, "factory values need no file");
    }

    #[test]
    fn saved_data_loads_back_bit_for_bit() {
        let dir = folder("round-trip");
        let robot = robot();
        let (mut data, _) = UserData::load(&dir, &robot);
        // Values that decimal text could round: they must come back identical.
        data.write_tool(3, STAMP, tool(0.1), false).unwrap();
        data.write_tool(15, STAMP, tool(f32::MIN_POSITIVE), false)
            .unwrap();
        let stored = data.take_unsaved().unwrap();
        save(&dir, &robot.name, &stored).unwrap();
        let (mut loaded, warnings) = UserData::load(&dir, &robot);
        assert!(warnings.is_empty(), "{warnings:?}");
        assert_eq!(
            loaded.read_tool(3).unwrap(),
            (3, Entry::written(STAMP, tool(0.1)))
        );
        assert_eq!(
            loaded.read_tool(15).unwrap().1.data,
            tool(f32::MIN_POSITIVE)
        );
        assert_eq!(loaded.change_index(DataSet::Tool), 2);
        assert_eq!(loaded.take_unsaved(), None, "nothing changed since loading");
        // Saving what was loaded gives the same file.
        let first = fs::read_to_string(dir.join(FILE_NAME)).unwrap();
        save(&dir, &robot.name, &stored).unwrap();
        assert_eq!(fs::read_to_string(dir.join(FILE_NAME)).unwrap(), first);
        let _ = fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_leftover_temporary_file_is_ignored_and_replaced() {
        let dir = folder("leftover");
        let robot = robot();
        let mut data = saved(&dir, &robot);
        // A crash in the middle of the next save left half a file behind.
        fs::write(dir.join(TEMP_NAME), "format = 1\nrobot = \"JAKA").unwrap();
        let (loaded, warnings) = UserData::load(&dir, &robot);
        assert!(warnings.is_empty(), "{warnings:?}");
        assert_eq!(loaded.read_tool(1).unwrap().1.data, tool(5.0));
        data.write_tool(2, STAMP, tool(6.0), false).unwrap();
        save(&dir, &robot.name, &data.take_unsaved().unwrap()).unwrap();
        assert!(!dir.join(TEMP_NAME).exists());
        let (loaded, _) = UserData::load(&dir, &robot);
        assert_eq!(loaded.read_tool(2).unwrap().1.data, tool(6.0));
        let _ = fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_corrupt_file_is_kept_aside_and_factory_values_are_restored() {
        let dir = folder("corrupt");
        let robot = robot();
        for (n, text) in [(1, "format = 1\nrobot = "), (2, "format = 99\n")] {
            saved(&dir, &robot);
            fs::write(dir.join(FILE_NAME), text).unwrap();
            let (mut data, warnings) = UserData::load(&dir, &robot);
            let [UserDataWarning::Corrupt { kept, .. }] = &warnings[..] else {
                panic!("{warnings:?}");
            };
            let kept = kept.clone().unwrap();
            assert_eq!(kept, dir.join(format!("{FILE_NAME}.corrupt-{n}")));
            assert_eq!(
                fs::read_to_string(&kept).unwrap(),
                text,
                "bad file kept as it was"
            );
            assert!(!dir.join(FILE_NAME).exists());
            assert_eq!(data.read_tool(1).unwrap().1.data, ToolData::default());
            for set in DataSet::ALL {
                assert!(data.data_changed(set), "{set:?}");
                assert_eq!(data.change_index(set), 1, "{set:?}");
            }
            assert!(data.take_unsaved().is_some(), "the restore is saved");
        }
        let _ = fs::remove_dir_all(&dir);
    }

    #[test]
    fn an_unreadable_file_is_kept_aside_too() {
        let dir = folder("unreadable");
        // A folder where the file should be: reading it fails (not with NotFound).
        fs::create_dir_all(dir.join(FILE_NAME)).unwrap();
        let (data, warnings) = UserData::load(&dir, &robot());
        assert!(
            matches!(
                &warnings[..],
                [UserDataWarning::Unreadable { kept: Some(_), .. }]
            ),
            "{warnings:?}"
        );
        assert!(data.data_changed(DataSet::Tool));
        assert!(!dir.join(FILE_NAME).exists());
        let _ = fs::remove_dir_all(&dir);
    }

    #[test]
    fn entries_against_this_robot_are_reset_with_data_changed() {
        let dir = folder("adjusted");
        let robot = robot();
        let mut data = saved(&dir, &robot);
        data.write_load(
            4,
            STAMP,
            LoadData {
                mass_kg: 2.0,
                ..LoadData::default()
            },
            false,
        )
        .unwrap();
        let mut stored = data.take_unsaved().unwrap();
        // Saved on a robot with a bigger payload, for another robot name.
        stored.loads[4].data.mass_kg = 100.0;
        save(&dir, "JAKA Zu 18", &stored).unwrap();
        let (mut loaded, warnings) = UserData::load(&dir, &robot);
        let [UserDataWarning::Adjusted { sets }] = &warnings[..] else {
            panic!("{warnings:?}");
        };
        assert_eq!(sets, &[DataSet::Load, DataSet::SwLimits]);
        let (_, load5) = loaded.read_load(5).unwrap();
        assert!(load5.data_changed);
        assert_eq!(load5.data, LoadData::default());
        assert_eq!(
            loaded.read_load(4).unwrap().1.data.mass_kg,
            2.0,
            "valid loads kept"
        );
        assert!(loaded.sw_limits().data_changed);
        assert_eq!(loaded.read_tool(1).unwrap().1.data, tool(5.0), "tools kept");
        assert_eq!(loaded.change_index(DataSet::Load), 2);
        assert!(loaded.take_unsaved().is_some(), "the adjustment is saved");
        let _ = fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_file_from_before_the_deceleration_rate_loads_with_the_acceleration_rate() {
        let dir = folder("old-default-dynamics");
        let robot = robot();
        saved(&dir, &robot);
        let file = dir.join(FILE_NAME);
        let text = fs::read_to_string(&file).unwrap();
        let old: String = text
            .lines()
            .filter(|l| !l.starts_with("deceleration_rate"))
            .map(|l| format!("{l}\n"))
            .collect();
        assert_ne!(old, text, "the file has a deceleration rate to remove");
        fs::write(&file, old).unwrap();
        let (loaded, warnings) = UserData::load(&dir, &robot);
        assert!(warnings.is_empty(), "{warnings:?}");
        let rates = loaded.default_rates();
        assert_eq!(rates.deceleration, rates.acceleration);
        assert!(!loaded.data_changed(DataSet::DefaultDynamics));
        let _ = fs::remove_dir_all(&dir);
    }

    #[test]
    fn the_saver_writes_the_newest_data_and_reports_failures() {
        let dir = folder("saver");
        let robot = robot();
        let (mut data, _) = UserData::load(&dir, &robot);
        let saver = Saver::spawn(dir.clone(), robot.name.clone()).unwrap();
        for x in [1.0, 2.0, 3.0] {
            data.write_tool(1, STAMP, tool(x), false).unwrap();
            saver.submit(data.take_unsaved().unwrap());
        }
        drop(saver);
        let (loaded, warnings) = UserData::load(&dir, &robot);
        assert!(warnings.is_empty(), "{warnings:?}");
        assert_eq!(loaded.read_tool(1).unwrap().1.data, tool(3.0));

        // A file where the folder should be: saving cannot work.
        let blocked = dir.join("blocked");
        fs::write(&blocked, "").unwrap();
        let saver = Saver::spawn(blocked, robot.name.clone()).unwrap();
        let mut changed = loaded;
        changed.write_tool(2, STAMP, tool(4.0), false).unwrap();
        saver.submit(changed.take_unsaved().unwrap());
        let failure = (0..500).find_map(|_| {
            std::thread::sleep(std::time::Duration::from_millis(2));
            saver.take_failure()
        });
        assert!(
            matches!(failure, Some(PersistError::Write { .. })),
            "{failure:?}"
        );
        let _ = fs::remove_dir_all(&dir);
    }
}
