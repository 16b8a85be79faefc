//! Real-time scheduling of a service's cyclic thread, as `[realtime.<service>]` configures it:
//! CPU pinning, locked and prefaulted memory, SCHED_FIFO.
//!
//! [`SchedulingPlan`] is the pure part (what a section asks for); [`apply`] carries it out on
//! the calling thread. A section with everything off asks for nothing and makes no system call,
//! so the default configuration needs no privileges.

use core::fmt;

use crate::config::ThreadScheduling;

/// Stack touched once after locking memory, so the cycle never page-faults on its own stack.
pub const PREFAULT_STACK_BYTES: usize = 256 * 1024;

/// Stride of the stack prefault; the smallest page size Linux uses, so every page is touched.
const PREFAULT_STRIDE: usize = 4096;

/// What one `[realtime.<service>]` section asks for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SchedulingPlan {
    /// The CPU to pin the thread to; `None` = any.
    pub cpu: Option<usize>,
    /// Lock all memory of the process (now and future) and prefault the stack.
    pub lock_memory: bool,
    /// SCHED_FIFO with this priority; `None` = keep the thread's normal scheduling.
    pub fifo_priority: Option<u8>,
}

impl SchedulingPlan {
    /// The plan for one section: priority 0 and cpu -1 (or any negative cpu) mean "leave as is".
    pub fn from_settings(settings: &ThreadScheduling) -> Self {
        Self {
            cpu: usize::try_from(settings.cpu).ok(),
            lock_memory: settings.lock_memory,
            fifo_priority: (settings.priority > 0).then_some(settings.priority),
        }
    }

    /// True when the plan changes nothing.
    pub fn is_empty(&self) -> bool {
        self.cpu.is_none() && !self.lock_memory && self.fifo_priority.is_none()
    }
}

impl fmt::Display for SchedulingPlan {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.fifo_priority {
            Some(priority) => write!(f, "SCHED_FIFO priority {priority}")?,
            None => f.write_str("normal scheduling")?,
        }
        match self.cpu {
            Some(cpu) => write!(f, ", pinned to CPU {cpu}")?,
            None => f.write_str(", any CPU")?,
        }
        if self.lock_memory {
            f.write_str(", memory locked")?;
        }
        Ok(())
    }
}

/// An error number of a failed system call, shown by its C name where the hint depends on it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Errno(pub i32);

impl Errno {
    fn last() -> Self {
        Self(std::io::Error::last_os_error().raw_os_error().unwrap_or(0))
    }
}

impl fmt::Display for Errno {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let name = match self.0 {
            libc::EPERM => "EPERM",
            libc::EINVAL => "EINVAL",
            libc::ENOMEM => "ENOMEM",
            libc::EAGAIN => "EAGAIN",
            libc::ESRCH => "ESRCH",
            other => return write!(f, "errno {other}"),
        };
        f.write_str(name)
    }
}

/// A `[realtime.<service>]` setting could not be applied. The text names the key, the value,
/// the error and what to change (privileges, unit limits, CPU numbers).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum RealtimeError {
    #[error(
        "realtime.{service}.cpu = {cpu}: cannot pin the thread to this CPU ({errno}): {}",
        affinity_hint(*.errno)
    )]
    Affinity {
        service: &'static str,
        cpu: usize,
        errno: Errno,
    },
    #[error(
        "realtime.{service}.lock_memory = true: mlockall failed ({errno}): {}",
        lock_memory_hint(*.errno)
    )]
    LockMemory { service: &'static str, errno: Errno },
    #[error(
        "realtime.{service}.priority = {priority}: SCHED_FIFO {}",
        priority_hint(*.priority, *.errno)
    )]
    Priority {
        service: &'static str,
        priority: u8,
        errno: Errno,
    },
}

fn affinity_hint(errno: Errno) -> &'static str {
    match errno.0 {
        libc::EINVAL => {
            "no such CPU online, or not allowed for this process (see `nproc`, the unit's \
             CPUAffinity= and the cgroup's cpuset)"
        }
        libc::EPERM => "not permitted: run as root or give the unit CAP_SYS_NICE",
        _ => "the kernel refused the CPU mask",
    }
}

fn lock_memory_hint(errno: Errno) -> &'static str {
    match errno.0 {
        libc::ENOMEM => {
            "the memlock limit is too small: run as root, or give the unit LimitMEMLOCK=infinity \
             / CAP_IPC_LOCK"
        }
        libc::EPERM => {
            "not permitted: run as root, or give the unit LimitMEMLOCK=infinity / CAP_IPC_LOCK"
        }
        _ => "not enough memory could be locked",
    }
}

fn priority_hint(priority: u8, errno: Errno) -> String {
    match errno.0 {
        libc::EPERM => format!(
            "not permitted ({errno}): run as root, or give the unit LimitRTPRIO={priority} (or \
             higher) / CAP_SYS_NICE"
        ),
        _ => format!("refused ({errno}): the priority must be 1..=99"),
    }
}

/// Applies `plan` to the calling thread (memory locking to the whole process), as
/// `[realtime.<service>]` of `service` asked. Order: CPU, memory, then SCHED_FIFO, so the
/// slow start-up work (locking and faulting in all memory) does not yet run at real-time
/// priority. Threads created afterwards inherit the priority and the CPU: create non-real-time
/// helpers before. An empty plan makes no system call.
pub fn apply(service: &'static str, plan: &SchedulingPlan) -> Result<(), RealtimeError> {
    if plan.is_empty() {
        return Ok(());
    }
    if let Some(cpu) = plan.cpu {
        pin_to_cpu(cpu).map_err(|errno| RealtimeError::Affinity {
            service,
            cpu,
            errno,
        })?;
    }
    if plan.lock_memory {
        lock_memory().map_err(|errno| RealtimeError::LockMemory { service, errno })?;
        prefault_stack();
    }
    if let Some(priority) = plan.fifo_priority {
        set_fifo(priority).map_err(|errno| RealtimeError::Priority {
            service,
            priority,
            errno,
        })?;
    }
    tracing::info!(service, "real-time settings applied: {plan}");
    Ok(())
}

fn pin_to_cpu(cpu: usize) -> Result<(), Errno> {
    // CPU_SET indexes a fixed-size mask: a larger number is no CPU of this machine.
    if cpu >= libc::CPU_SETSIZE as usize {
        return Err(Errno(libc::EINVAL));
    }
    // SAFETY: an all-zero cpu_set_t is the empty set; CPU_SET stays within it (checked
    // above); pid 0 is the calling thread and the size is that of the set passed.
    let status = unsafe {
        let mut set: libc::cpu_set_t = core::mem::zeroed();
        libc::CPU_SET(cpu, &mut set);
        libc::sched_setaffinity(0, core::mem::size_of::<libc::cpu_set_t>(), &set)
    };
    if status == 0 {
        Ok(())
    } else {
        Err(Errno::last())
    }
}

fn lock_memory() -> Result<(), Errno> {
    // SAFETY: mlockall takes only flags and touches no memory of ours.
    if unsafe { libc::mlockall(libc::MCL_CURRENT | libc::MCL_FUTURE) } == 0 {
        Ok(())
    } else {
        Err(Errno::last())
    }
}

/// Touches [`PREFAULT_STACK_BYTES`] of stack below the caller, so those pages are resident
/// (and, after mlockall, locked) before the cycle first needs them.
#[inline(never)]
fn prefault_stack() {
    let mut stack = [0u8; PREFAULT_STACK_BYTES];
    for byte in stack.iter_mut().step_by(PREFAULT_STRIDE) {
        *byte = 1;
    }
    // Keeps the writes: without it the unused array would be optimised away.
    std::hint::black_box(&mut stack);
}

fn set_fifo(priority: u8) -> Result<(), Errno> {
    let param = libc::sched_param {
        sched_priority: i32::from(priority),
    };
    // SAFETY: pthread_self is the calling thread, and param is a valid sched_param.
    let status =
        unsafe { libc::pthread_setschedparam(libc::pthread_self(), libc::SCHED_FIFO, &param) };
    // pthread functions return the error number instead of setting errno.
    if status == 0 {
        Ok(())
    } else {
        Err(Errno(status))
    }
}

/// Makes the calling thread a background thread of a real-time service (threads inherit
/// their creator's policy and CPU): SCHED_OTHER at the lowest priority (nice 19), and where
/// the thread was pinned to one CPU of several, every other online CPU, so that its work
/// never delays the service's cycle. Not SCHED_IDLE: on a busy machine such a thread may not
/// run for long, and any lock it holds (a log stream's) would stall the threads waiting for
/// it.
pub fn make_background() -> Result<(), Errno> {
    let param = libc::sched_param { sched_priority: 0 };
    // SAFETY: pthread_self is the calling thread, and param is a valid sched_param.
    let status =
        unsafe { libc::pthread_setschedparam(libc::pthread_self(), libc::SCHED_OTHER, &param) };
    if status != 0 {
        return Err(Errno(status));
    }
    // SAFETY: gettid takes nothing; setpriority with a thread id sets that thread's nice
    // value on Linux.
    let status = unsafe {
        let tid = libc::gettid();
        libc::setpriority(libc::PRIO_PROCESS, tid as libc::id_t, 19)
    };
    if status != 0 {
        return Err(Errno::last());
    }
    // SAFETY: sysconf takes only a name.
    let online = unsafe { libc::sysconf(libc::_SC_NPROCESSORS_ONLN) };
    let online = usize::try_from(online)
        .unwrap_or(0)
        .min(libc::CPU_SETSIZE as usize);
    let pinned: Vec<usize> = allowed_cpus()?
        .into_iter()
        .filter(|&cpu| cpu < online)
        .collect();
    // SAFETY: the set is written by CPU_SET within its size; pid 0 is the calling thread and
    // the size is that of the set passed.
    unsafe {
        if let [cpu] = pinned[..]
            && online > 1
        {
            let mut others: libc::cpu_set_t = core::mem::zeroed();
            for other in (0..online).filter(|&other| other != cpu) {
                libc::CPU_SET(other, &mut others);
            }
            if libc::sched_setaffinity(0, core::mem::size_of::<libc::cpu_set_t>(), &others) != 0 {
                return Err(Errno::last());
            }
        }
    }
    Ok(())
}

/// The CPUs the calling thread may run on.
fn allowed_cpus() -> Result<Vec<usize>, Errno> {
    // SAFETY: the set is written by the kernel and read within its size; pid 0 is the calling
    // thread and the size is that of the set passed.
    unsafe {
        let mut set: libc::cpu_set_t = core::mem::zeroed();
        if libc::sched_getaffinity(0, core::mem::size_of::<libc::cpu_set_t>(), &mut set) != 0 {
            return Err(Errno::last());
        }
        Ok((0..libc::CPU_SETSIZE as usize)
            .filter(|&cpu| libc::CPU_ISSET(cpu, &set))
            .collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_background_thread_leaves_a_pinned_cpu_and_runs_at_the_lowest_priority() {
        let cpus = allowed_cpus().expect("affinity");
        let handle = std::thread::spawn(move || {
            pin_to_cpu(cpus[0]).expect("pin");
            make_background().expect("background");
            // SAFETY: pid 0 is the calling thread; getpriority of a thread id reads that
            // thread's nice value.
            let (policy, nice) = unsafe {
                (
                    libc::sched_getscheduler(0),
                    libc::getpriority(libc::PRIO_PROCESS, libc::gettid() as libc::id_t),
                )
            };
            (policy, nice, allowed_cpus().expect("affinity"))
        });
        let (policy, nice, after) = handle.join().expect("thread");
        assert_eq!((policy, nice), (libc::SCHED_OTHER, 19));
        // SAFETY: sysconf takes only a name.
        if unsafe { libc::sysconf(libc::_SC_NPROCESSORS_ONLN) } > 1 {
            assert!(
                !after.is_empty() && !after.contains(&allowed_cpus().expect("affinity")[0]),
                "{after:?}"
            );
        }
    }

    fn settings(priority: u8, cpu: i16, lock_memory: bool) -> ThreadScheduling {
        ThreadScheduling {
            priority,
            cpu,
            lock_memory,
        }
    }

    /// The CPUs the calling thread may run on.
    fn is_root() -> bool {
        // SAFETY: geteuid has no preconditions.
        unsafe { libc::geteuid() == 0 }
    }

    /// The calling thread's scheduling policy and priority.
    fn scheduling() -> (i32, i32) {
        let mut param = libc::sched_param { sched_priority: 0 };
        let mut policy = 0;
        // SAFETY: both out-pointers are valid for the call.
        let status =
            unsafe { libc::pthread_getschedparam(libc::pthread_self(), &mut policy, &mut param) };
        assert_eq!(status, 0);
        (policy, param.sched_priority)
    }

    #[test]
    fn everything_off_plans_nothing_and_changes_nothing() {
        let plan = SchedulingPlan::from_settings(&settings(0, -1, false));
        assert!(plan.is_empty());
        assert_eq!(plan.to_string(), "normal scheduling, any CPU");
        let (before, after) = std::thread::spawn(move || {
            let before = (allowed_cpus().expect("affinity"), scheduling());
            apply("servo", &plan).unwrap();
            (before, (allowed_cpus().expect("affinity"), scheduling()))
        })
        .join()
        .unwrap();
        assert_eq!(before, after);
    }

    #[test]
    fn each_setting_alone_makes_the_plan_non_empty() {
        let fifo = SchedulingPlan::from_settings(&settings(80, -1, false));
        assert_eq!(fifo.fifo_priority, Some(80));
        assert!(!fifo.is_empty());
        let pinned = SchedulingPlan::from_settings(&settings(0, 1, false));
        assert_eq!(pinned.cpu, Some(1));
        assert!(!pinned.is_empty());
        let locked = SchedulingPlan::from_settings(&settings(0, -1, true));
        assert!(locked.lock_memory && !locked.is_empty());
        assert_eq!(
            SchedulingPlan::from_settings(&settings(80, 1, true)).to_string(),
            "SCHED_FIFO priority 80, pinned to CPU 1, memory locked"
        );
    }

    #[test]
    fn pinning_to_an_allowed_cpu_works_unprivileged() {
        let cpu = allowed_cpus().expect("affinity")[0];
        // Its own thread, so the test runner's threads keep their CPUs.
        let pinned = std::thread::spawn(move || {
            let plan = SchedulingPlan::from_settings(&settings(0, cpu as i16, false));
            apply("servo", &plan).map(|()| allowed_cpus().expect("affinity"))
        })
        .join()
        .unwrap();
        assert_eq!(pinned, Ok(vec![cpu]));
    }

    #[test]
    fn pinning_to_a_missing_cpu_names_the_key_and_the_cause() {
        let err = std::thread::spawn(|| {
            let plan = SchedulingPlan::from_settings(&settings(0, 1023, false));
            apply("planner", &plan)
        })
        .join()
        .unwrap()
        .unwrap_err();
        assert_eq!(
            err,
            RealtimeError::Affinity {
                service: "planner",
                cpu: 1023,
                errno: Errno(libc::EINVAL)
            }
        );
        let text = err.to_string();
        assert!(
            text.starts_with("realtime.planner.cpu = 1023: cannot pin the thread to this CPU (EINVAL): no such CPU online"),
            "{text}"
        );
    }

    #[test]
    fn sched_fifo_is_applied_when_running_as_root() {
        if !is_root() {
            eprintln!(
                "skipped: SCHED_FIFO needs root (or CAP_SYS_NICE), and this test is not root"
            );
            return;
        }
        let applied = std::thread::spawn(|| {
            let plan = SchedulingPlan::from_settings(&settings(10, -1, false));
            apply("servo", &plan).map(|()| scheduling())
        })
        .join()
        .unwrap();
        assert_eq!(applied, Ok((libc::SCHED_FIFO, 10)));
    }

    #[test]
    fn memory_is_locked_when_running_as_root() {
        if !is_root() {
            eprintln!("skipped: mlockall of the whole test process needs root (or LimitMEMLOCK)");
            return;
        }
        let plan = SchedulingPlan::from_settings(&settings(0, -1, true));
        apply("servo", &plan).unwrap();
        let status = std::fs::read_to_string("/proc/self/status").unwrap();
        // SAFETY: munlockall takes no arguments; it undoes the lock for the other tests.
        unsafe { libc::munlockall() };
        let locked_kib: u64 = status
            .lines()
            .find_map(|line| line.strip_prefix("VmLck:"))
            .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
            .unwrap();
        assert!(
            locked_kib >= (PREFAULT_STACK_BYTES / 1024) as u64,
            "VmLck {locked_kib} kB"
        );
    }

    #[test]
    fn errors_say_what_to_change() {
        let fifo = RealtimeError::Priority {
            service: "servo",
            priority: 80,
            errno: Errno(libc::EPERM),
        };
        assert_eq!(
            fifo.to_string(),
            "realtime.servo.priority = 80: SCHED_FIFO not permitted (EPERM): run as root, or \
             give the unit LimitRTPRIO=80 (or higher) / CAP_SYS_NICE"
        );
        let memory = RealtimeError::LockMemory {
            service: "planner",
            errno: Errno(libc::ENOMEM),
        };
        assert_eq!(
            memory.to_string(),
            "realtime.planner.lock_memory = true: mlockall failed (ENOMEM): the memlock limit \
             is too small: run as root, or give the unit LimitMEMLOCK=infinity / CAP_IPC_LOCK"
        );
        assert_eq!(Errno(12345).to_string(), "errno 12345");
    }
}
