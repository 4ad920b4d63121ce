//! Service names and builders shared by the daemon's publishers and any subscriber.
//!
//! Both sides call the same builder with the same settings (`open_or_create`), so whichever starts
//! first creates the service and the other opens it; a subscriber asking for a larger buffer than
//! the service offers gets a clear incompatibility error.
//!
//! **The iceoryx2 root.** Every node is built from an iceoryx2 config made here ([`iox_config`]),
//! never from a file: iceoryx2 would otherwise read `./config/iceoryx2.toml` from the working
//! directory first, then the user's and the system's. The config puts iceoryx2's files under
//! `publish.root` and names its shared-memory segments in `/dev/shm` with the prefix
//! [`SHM_PREFIX`], apart from other iceoryx2 applications. `publish.root = "auto"` (the default)
//! is resolved by [`resolve_root`], the one rule the daemon, `mosaicd listen` and the Python client
//! share, so a subscriber of the daemon's user finds the daemon's root with no option:
//!
//! 1. `$RUNTIME_DIRECTORY/iceoryx2` (its first `:`-separated entry) when set: systemd sets it to
//!    `/run/mosaicd` for the units' `RuntimeDirectory=mosaicd`;
//! 2. `/run/mosaicd/iceoryx2` for root, and for a user who owns the directory `/run/mosaicd` (the
//!    units' user `mosaicd`, whose subscribers have no `RUNTIME_DIRECTORY`);
//! 3. `$XDG_RUNTIME_DIR/mosaicd/iceoryx2` when that is a directory of this user (a login session's
//!    `/run/user/<uid>`) and the path fits iceoryx2's limit ([`MAX_ROOT_LEN`] bytes);
//! 4. `/tmp/mosaicd-<uid>/iceoryx2`, whose parent is created `0700` and refused when another user
//!    owns it ([`root_dir`]).
//!
//! Relative or empty variables count as unset. Before a node is created ([`create_node`]) the root
//! is checked: it is
//! created `0750` when missing, and an existing root (or the `/dev/shm` management segment) that
//! belongs to another user is refused with one line naming the path and its owner — another user
//! cannot make the daemon use, or fail on, files it planted. The management segment, which
//! iceoryx2 creates `0666` for every user, is set to `0600`.
//!
//! **Who can publish and subscribe.** Each service admits one publisher ([`MAX_PUBLISHERS`]): the
//! daemon. A second publisher (another process of the same user) is refused. iceoryx2 0.10 sets
//! the modes of what it creates itself (`fchmod`, the umask does not apply): services' shared
//! memory `0600`, their static files `0400`, directories `0750`. So subscribers run as the
//! daemon's user (`mosaicd` under systemd); members of the group `mosaicd` can traverse the root
//! but not open services (docs/daemon.md, "Shared memory and subscribers").
//!
//! ```
//! use mosaicd::publish::service_name;
//! assert_eq!(service_name("mosaicd", "front", "detections"), "mosaicd/front/detections");
//! ```

use std::ffi::{OsStr, OsString};
use std::os::unix::ffi::OsStrExt;
use std::os::unix::fs::{DirBuilderExt, MetadataExt, PermissionsExt};
use std::path::{Path, PathBuf};

use iceoryx2::port::publisher::{Publisher, PublisherCreateError};
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::*;
use iceoryx2::service::port_factory::publish_subscribe::PortFactory;
use iceoryx2::service::port_factory::PortFactory as _;

use crate::config::Iox2Root;

use super::messages::{DescriptorsMsg, DetectionsMsg, GradientsHeader, KeypointsMsg, StatsMsg};

/// Publishers per service: only the daemon publishes. A daemon killed with SIGKILL leaves its
/// publisher behind; the next start's node creation removes it (dead-node clean-up) before the new
/// publisher takes the slot.
pub(crate) const MAX_PUBLISHERS: usize = 1;
/// Prefix of every file and shared-memory segment name iceoryx2 creates for mosaicd.
pub(crate) const SHM_PREFIX: &str = "mosaicd_";
/// Mode of the root directory the daemon creates (owner all, group traverse and list).
const ROOT_MODE: u32 = 0o750;
/// Mode the `/dev/shm` management segment is set to (iceoryx2 creates it `0666`).
const MGMT_SEGMENT_MODE: u32 = 0o600;
/// Subscribers per service.
const MAX_SUBSCRIBERS: usize = 16;
/// Samples kept for late subscribers.
const HISTORY: usize = 1;
/// Initial slice length of a gradients sample; grows as needed (power-of-two reallocation).
const GRADIENTS_INITIAL_SLICE: usize = 1 << 16;

/// Errors of the iceoryx2 layer, with what was being done.
#[derive(Debug, thiserror::Error)]
pub enum PublishError {
    /// An iceoryx2 call failed.
    #[error("iceoryx2: {context}: {message}")]
    Iceoryx {
        /// What was being done (service name, operation).
        context: String,
        /// iceoryx2's error.
        message: String,
    },
    /// A path of the iceoryx2 root (or its `/dev/shm` segment) belongs to another user.
    #[error("iceoryx2 root: {path} belongs to {owner}, not to this process's user {user}: another user created it; remove it, or set publish.root to a directory of this user")]
    ForeignOwner {
        /// The path.
        path: PathBuf,
        /// Its owner (`name (uid)`).
        owner: String,
        /// This process's effective user (`name (uid)`).
        user: String,
    },
    /// The root cannot be created or used.
    #[error("iceoryx2 root {path}: {what}: {source}")]
    Root {
        /// The path.
        path: PathBuf,
        /// What failed.
        what: &'static str,
        /// Cause.
        #[source]
        source: std::io::Error,
    },
    /// The root is not a usable path (not absolute, too long for iceoryx2, not a directory).
    #[error("iceoryx2 root {path}: {why}")]
    BadRoot {
        /// The path.
        path: PathBuf,
        /// What is wrong.
        why: String,
    },
    /// Another process already publishes on a service: only the daemon may.
    #[error("iceoryx2: {service}: another process already publishes on this service (one publisher per service: only the daemon publishes)")]
    PublisherTaken {
        /// The service.
        service: String,
    },
}

fn err(context: impl Into<String>, e: impl std::fmt::Display) -> PublishError {
    PublishError::Iceoryx {
        context: context.into(),
        message: e.to_string(),
    }
}

/// `name (uid)` of a user id (just the uid when it has no name).
fn user_label(uid: u32) -> String {
    let mut buf = vec![0 as libc::c_char; 4096];
    // SAFETY: an all-zero passwd is a valid value to be overwritten by getpwuid_r.
    let mut pwd: libc::passwd = unsafe { std::mem::zeroed() };
    let mut out: *mut libc::passwd = std::ptr::null_mut();
    // SAFETY: every pointer is valid for the call and `buf.len()` is the buffer's size; on
    // success `out` points to `pwd`, whose strings live in `buf`.
    let rc = unsafe { libc::getpwuid_r(uid, &mut pwd, buf.as_mut_ptr(), buf.len(), &mut out) };
    if rc == 0 && !out.is_null() && !pwd.pw_name.is_null() {
        // SAFETY: getpwuid_r succeeded, so `pw_name` is a NUL-terminated string inside `buf`.
        let name = unsafe { std::ffi::CStr::from_ptr(pwd.pw_name) };
        format!("{} (uid {uid})", name.to_string_lossy())
    } else {
        format!("uid {uid}")
    }
}

fn euid() -> u32 {
    // SAFETY: geteuid has no preconditions and cannot fail.
    unsafe { libc::geteuid() }
}

/// Refuse `path` when it exists and another user owns it.
fn check_owner(path: &Path, meta: &std::fs::Metadata) -> Result<(), PublishError> {
    if meta.uid() != euid() {
        return Err(PublishError::ForeignOwner {
            path: path.to_path_buf(),
            owner: user_label(meta.uid()),
            user: user_label(euid()),
        });
    }
    Ok(())
}

/// The segment-name prefix of the nodes under `root`: `"mosaicd_"`, then the 32-bit FNV-1a hash
/// of the root's bytes in hex, then `_` (`mosaicd_1a2b3c4d_`). iceoryx2 names its `/dev/shm`
/// segments (the management segment too) by the prefix alone, not by the root: one prefix per
/// root keeps the daemons of different users (each with its own root) apart, where one shared
/// management segment, narrowed to its first user, would lock every other user out. The Python
/// client computes the same (`segment_prefix`).
///
/// ```
/// use mosaicd::publish::segment_prefix;
/// assert_eq!(segment_prefix(std::path::Path::new("/run/mosaicd/iceoryx2")), "mosaicd_9ed403be_");
/// ```
pub fn segment_prefix(root: &Path) -> String {
    let hash = root.as_os_str().as_bytes().iter().fold(0x811c_9dc5_u32, |h, &b| {
        (h ^ u32::from(b)).wrapping_mul(0x0100_0193)
    });
    format!("{SHM_PREFIX}{hash:08x}_")
}

/// The iceoryx2 config of every mosaicd node: files under `root`, segment names with
/// [`segment_prefix`]. Built here, so no config file is read (not `./config/iceoryx2.toml`).
pub(crate) fn iox_config(root: &Path) -> Result<Config, PublishError> {
    let bad = |why: String| PublishError::BadRoot {
        path: root.to_path_buf(),
        why,
    };
    if !root.is_absolute() {
        return Err(bad("publish.root must be an absolute path".into()));
    }
    let iox_root = iceoryx2::prelude::Path::new(root.as_os_str().as_bytes())
        .map_err(|e| bad(format!("not a path iceoryx2 accepts ({e:?})")))?;
    let prefix =
        FileName::new(segment_prefix(root).as_bytes()).map_err(|e| bad(format!("segment prefix: {e:?}")))?;
    let mut cfg = Config::default();
    cfg.global.set_root_path(&iox_root);
    cfg.global.prefix = prefix;
    Ok(cfg)
}

/// Longest root iceoryx2 accepts, in bytes (its `Path` capacity on Linux).
pub(crate) const MAX_ROOT_LEN: usize = 255;
/// The system runtime directory of mosaicd (the units' `RuntimeDirectory=mosaicd`).
pub(crate) const SYSTEM_RUNTIME_DIR: &str = "/run/mosaicd";
/// Name of the root inside the runtime directory that holds it.
const ROOT_NAME: &str = "iceoryx2";
/// Mode of the private `/tmp/mosaicd-<uid>` directory.
const PRIVATE_DIR_MODE: u32 = 0o700;

/// What `publish.root = "auto"` depends on: the process's user and environment, and the two fixed
/// base directories (parameters so that tests need neither users nor `/run`).
#[derive(Debug, Clone)]
pub struct RootEnv {
    /// The effective user id.
    pub uid: u32,
    /// `$RUNTIME_DIRECTORY` (set by systemd for `RuntimeDirectory=`).
    pub runtime_directory: Option<OsString>,
    /// `$XDG_RUNTIME_DIR` (a login session's `/run/user/<uid>`).
    pub xdg_runtime_dir: Option<OsString>,
    /// `/run/mosaicd`.
    pub system_dir: PathBuf,
    /// `/tmp` (fixed: `$TMPDIR` is not shared by every process of a user).
    pub tmp_dir: PathBuf,
}

impl RootEnv {
    /// This process's user and environment.
    pub fn current() -> Self {
        Self {
            uid: euid(),
            runtime_directory: std::env::var_os("RUNTIME_DIRECTORY"),
            xdg_runtime_dir: std::env::var_os("XDG_RUNTIME_DIR"),
            system_dir: PathBuf::from(SYSTEM_RUNTIME_DIR),
            tmp_dir: PathBuf::from("/tmp"),
        }
    }
}

/// Which rule chose a root (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RootOrigin {
    /// `publish.root` / `--root` named it.
    Configured,
    /// `$RUNTIME_DIRECTORY/iceoryx2` (systemd).
    RuntimeDirectory,
    /// `/run/mosaicd/iceoryx2` (root, or the owner of `/run/mosaicd`).
    System,
    /// `$XDG_RUNTIME_DIR/mosaicd/iceoryx2`.
    XdgRuntimeDir,
    /// `/tmp/mosaicd-<uid>/iceoryx2`.
    PrivateTmp,
}

impl RootOrigin {
    /// How the root was chosen, for the log.
    pub fn describe(self) -> &'static str {
        match self {
            Self::Configured => "set by publish.root / --root",
            Self::RuntimeDirectory => "auto: $RUNTIME_DIRECTORY",
            Self::System => "auto: /run/mosaicd",
            Self::XdgRuntimeDir => "auto: $XDG_RUNTIME_DIR",
            Self::PrivateTmp => "auto: private directory in /tmp",
        }
    }
}

/// A directory variable's value as an absolute path (`RUNTIME_DIRECTORY`: its first entry).
fn absolute_dir(value: Option<&OsStr>, first_entry: bool) -> Option<PathBuf> {
    let value = value?.as_bytes();
    let value = if first_entry {
        value.split(|&b| b == b':').next().unwrap_or_default()
    } else {
        value
    };
    let path = Path::new(OsStr::from_bytes(value));
    path.is_absolute().then(|| path.to_path_buf())
}

/// `path` is a directory (not a symbolic link) owned by `uid`.
fn dir_owned_by(path: &Path, uid: u32) -> bool {
    std::fs::symlink_metadata(path).is_ok_and(|m| m.is_dir() && m.uid() == uid)
}

/// The iceoryx2 root of `setting` for the user and environment `env` (only reads the metadata of
/// `$XDG_RUNTIME_DIR` and `/run/mosaicd`; creates nothing). The rules are in the module
/// documentation; [`root_dir`] applies them to this process and prepares `/tmp/mosaicd-<uid>`.
pub fn resolve_root(setting: &Iox2Root, env: &RootEnv) -> (PathBuf, RootOrigin) {
    if let Iox2Root::Path(p) = setting {
        return (p.clone(), RootOrigin::Configured);
    }
    if let Some(dir) = absolute_dir(env.runtime_directory.as_deref(), true) {
        return (dir.join(ROOT_NAME), RootOrigin::RuntimeDirectory);
    }
    if env.uid == 0 || dir_owned_by(&env.system_dir, env.uid) {
        return (env.system_dir.join(ROOT_NAME), RootOrigin::System);
    }
    if let Some(dir) = absolute_dir(env.xdg_runtime_dir.as_deref(), false) {
        let root = dir.join("mosaicd").join(ROOT_NAME);
        if dir_owned_by(&dir, env.uid) && root.as_os_str().len() <= MAX_ROOT_LEN {
            return (root, RootOrigin::XdgRuntimeDir);
        }
    }
    let private = env.tmp_dir.join(format!("mosaicd-{}", env.uid));
    (private.join(ROOT_NAME), RootOrigin::PrivateTmp)
}

/// Create the private directory `dir` (`/tmp/mosaicd-<uid>`) `0700` when missing; refuse it when
/// another user owns it (planted in the shared `/tmp`) or it is not a directory; narrow its mode to
/// `0700` otherwise.
pub(crate) fn prepare_private_dir(dir: &Path) -> Result<(), PublishError> {
    let io = |what| {
        move |source| PublishError::Root {
            path: dir.to_path_buf(),
            what,
            source,
        }
    };
    match std::fs::DirBuilder::new().mode(PRIVATE_DIR_MODE).create(dir) {
        Ok(()) => {}
        Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {}
        Err(e) => return Err(io("cannot create it")(e)),
    }
    let meta = std::fs::symlink_metadata(dir).map_err(io("cannot inspect it"))?;
    check_owner(dir, &meta)?;
    if !meta.is_dir() {
        return Err(PublishError::BadRoot {
            path: dir.to_path_buf(),
            why: "exists and is not a directory".into(),
        });
    }
    if meta.mode() & 0o7777 != PRIVATE_DIR_MODE {
        std::fs::set_permissions(dir, std::fs::Permissions::from_mode(PRIVATE_DIR_MODE))
            .map_err(io("cannot set its mode to 0700"))?;
    }
    Ok(())
}

/// This process's iceoryx2 root for `setting` ([`resolve_root`] with [`RootEnv::current`]), with
/// `/tmp/mosaicd-<uid>` prepared (`prepare_private_dir`) when that is where it resolved. The
/// root itself is prepared by [`create_node`].
pub fn root_dir(setting: &Iox2Root) -> Result<PathBuf, PublishError> {
    let (root, origin) = resolve_root(setting, &RootEnv::current());
    if origin == RootOrigin::PrivateTmp {
        if let Some(parent) = root.parent() {
            prepare_private_dir(parent)?;
        }
    }
    tracing::info!(root = %root.display(), origin = origin.describe(), "iceoryx2 root");
    Ok(root)
}

/// Where POSIX shared memory lives on Linux.
const SHM_DIR: &str = "/dev/shm";
/// Name ending of iceoryx2's management segment (`<prefix><type hash>_node.<version>.global_mgmt`).
const MGMT_SUFFIX: &str = ".global_mgmt";

/// The segments in `/dev/shm` of the nodes under `root` (names starting with its
/// [`segment_prefix`]), with their metadata.
fn our_segments(root: &Path) -> Vec<(PathBuf, std::fs::Metadata)> {
    let prefix = segment_prefix(root);
    let Ok(dir) = std::fs::read_dir(SHM_DIR) else {
        return Vec::new();
    };
    dir.filter_map(Result::ok)
        .filter(|e| e.file_name().as_bytes().starts_with(prefix.as_bytes()))
        .filter_map(|e| Some((e.path(), std::fs::symlink_metadata(e.path()).ok()?)))
        .collect()
}

/// Create `root` (mode 0750) when it is missing, and refuse it when it is not a directory. With
/// `owned` (the daemon, which publishes): also refuse a root another user owns, and a segment of
/// ours in `/dev/shm` ([`SHM_PREFIX`]) that another user (other than root) created. Subscribers
/// skip the ownership checks: they read what the daemon's user owns, and root may read anything.
pub(crate) fn prepare_root(root: &Path, owned: bool) -> Result<(), PublishError> {
    let io = |what| {
        move |source| PublishError::Root {
            path: root.to_path_buf(),
            what,
            source,
        }
    };
    match std::fs::symlink_metadata(root) {
        Ok(meta) => {
            if owned {
                check_owner(root, &meta)?;
            }
            if !meta.is_dir() {
                return Err(PublishError::BadRoot {
                    path: root.to_path_buf(),
                    why: "exists and is not a directory".into(),
                });
            }
            if meta.uid() == euid() && meta.mode() & 0o7777 != ROOT_MODE {
                std::fs::set_permissions(root, std::fs::Permissions::from_mode(ROOT_MODE))
                    .map_err(io("cannot set its mode to 0750"))?;
            }
        }
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            std::fs::DirBuilder::new()
                .recursive(true)
                .mode(ROOT_MODE)
                .create(root)
                .map_err(io(
                    "cannot create it (set publish.root to a directory this user may create)",
                ))?;
            // The umask may have narrowed the mode; the group keeps its traverse right.
            std::fs::set_permissions(root, std::fs::Permissions::from_mode(ROOT_MODE))
                .map_err(io("cannot set its mode to 0750"))?;
        }
        Err(e) => return Err(io("cannot inspect it")(e)),
    }
    if owned {
        for (path, meta) in our_segments(root) {
            // root's segments (an administrator's `mosaicd listen`) are not planted by a user
            if meta.uid() != 0 {
                check_owner(&path, &meta)?;
            }
        }
    }
    Ok(())
}

/// Narrow the management segment to its owner (iceoryx2 creates it `0666`, for every user).
fn narrow_mgmt_segment(root: &Path) {
    for (path, meta) in our_segments(root) {
        let mgmt = path.as_os_str().as_bytes().ends_with(MGMT_SUFFIX.as_bytes());
        if mgmt && meta.uid() == euid() && meta.mode() & 0o777 != MGMT_SEGMENT_MODE {
            if let Err(e) =
                std::fs::set_permissions(&path, std::fs::Permissions::from_mode(MGMT_SEGMENT_MODE))
            {
                tracing::warn!("cannot set {} to mode 0600: {e}", path.display());
            }
        }
    }
}

/// `<prefix>/<camera>/<topic>`.
pub fn service_name(prefix: &str, camera: &str, topic: &str) -> String {
    format!("{prefix}/{camera}/{topic}")
}

/// Create an ipc node under `root` (`publish.root`). `daemon = true`: the publishing side, whose
/// root and segments must be its own (`prepare_root`), and whose signals are left to the
/// daemon's own handlers; `false`: a subscriber. Dead nodes of crashed processes, and their
/// services' shared memory, are cleaned up here.
pub fn create_node(name: &str, daemon: bool, root: &Path) -> Result<Node<ipc::Service>, PublishError> {
    let config = iox_config(root)?;
    prepare_root(root, daemon)?;
    let node_name: NodeName = name
        .try_into()
        .map_err(|e| err(format!("node name {name:?}"), format!("{e:?}")))?;
    let mode = if daemon {
        SignalHandlingMode::Disabled
    } else {
        SignalHandlingMode::HandleTerminationRequests
    };
    // iceoryx2 logs its failures on stderr itself, and ours names them again (with the path):
    // keep its log to fatal errors unless IOX2_LOG_LEVEL says otherwise, so a failure is one line.
    set_log_level_from_env_or(LogLevel::Fatal);
    let node = NodeBuilder::new()
        .name(&node_name)
        .config(&config)
        .signal_handling_mode(mode)
        .create::<ipc::Service>()
        .map_err(|e| {
            // A subscriber of another user fails inside iceoryx2 (its files are its owner's only).
            let hint = match std::fs::metadata(root) {
                Ok(m) if m.uid() != euid() => format!(
                    " ({} belongs to {}: subscribers run as the daemon's user)",
                    root.display(),
                    user_label(m.uid())
                ),
                _ => String::new(),
            };
            err(
                format!("create node under {}", root.display()),
                format!("{e}{hint}"),
            )
        })?;
    narrow_mgmt_segment(root);
    let cleaned = node.try_cleanup_dead_nodes();
    if cleaned.cleanups > 0 || cleaned.failed_cleanups > 0 {
        tracing::info!(
            cleaned = cleaned.cleanups,
            failed = cleaned.failed_cleanups,
            "removed stale iceoryx2 resources of dead processes"
        );
    }
    Ok(node)
}

fn name(prefix: &str, camera: &str, topic: &str) -> Result<ServiceName, PublishError> {
    let s = service_name(prefix, camera, topic);
    s.as_str()
        .try_into()
        .map_err(|e| err(format!("service name {s:?}"), format!("{e:?}")))
}

/// A fixed-size publish-subscribe service `<prefix>/<camera>/<topic>` with the daemon's settings
/// (safe overflow, history, publisher and subscriber limits).
fn fixed_service<T: std::fmt::Debug + ZeroCopySend>(
    node: &Node<ipc::Service>,
    prefix: &str,
    camera: &str,
    topic: &str,
    buffer: usize,
) -> Result<PortFactory<ipc::Service, T, ()>, PublishError> {
    node.service_builder(&name(prefix, camera, topic)?)
        .publish_subscribe::<T>()
        .enable_safe_overflow(true)
        .subscriber_max_buffer_size(buffer)
        .history_size(HISTORY)
        .max_publishers(MAX_PUBLISHERS)
        .max_subscribers(MAX_SUBSCRIBERS)
        .open_or_create()
        .map_err(|e| err(service_name(prefix, camera, topic), e))
}

/// The detections service.
pub fn detections_service(
    node: &Node<ipc::Service>,
    prefix: &str,
    camera: &str,
    buffer: usize,
) -> Result<PortFactory<ipc::Service, DetectionsMsg, ()>, PublishError> {
    fixed_service(node, prefix, camera, "detections", buffer)
}

/// The stats service.
pub fn stats_service(
    node: &Node<ipc::Service>,
    prefix: &str,
    camera: &str,
    buffer: usize,
) -> Result<PortFactory<ipc::Service, StatsMsg, ()>, PublishError> {
    fixed_service(node, prefix, camera, "stats", buffer)
}

/// The keypoints service (mosaic SIFT keypoints, `compute.keypoints = true`).
pub fn keypoints_service(
    node: &Node<ipc::Service>,
    prefix: &str,
    camera: &str,
    buffer: usize,
) -> Result<PortFactory<ipc::Service, KeypointsMsg, ()>, PublishError> {
    fixed_service(node, prefix, camera, "keypoints", buffer)
}

/// The descriptors service (SIFT descriptors of the keypoints, `compute.keypoint_descriptors`).
pub fn descriptors_service(
    node: &Node<ipc::Service>,
    prefix: &str,
    camera: &str,
    buffer: usize,
) -> Result<PortFactory<ipc::Service, DescriptorsMsg, ()>, PublishError> {
    fixed_service(node, prefix, camera, "descriptors", buffer)
}

/// The gradients service (dynamic `[u8]` slices with a header).
pub fn gradients_service(
    node: &Node<ipc::Service>,
    prefix: &str,
    camera: &str,
    buffer: usize,
) -> Result<PortFactory<ipc::Service, [u8], GradientsHeader>, PublishError> {
    node.service_builder(&name(prefix, camera, "gradients")?)
        .publish_subscribe::<[u8]>()
        .user_header::<GradientsHeader>()
        .enable_safe_overflow(true)
        .subscriber_max_buffer_size(buffer)
        .history_size(HISTORY)
        .max_publishers(MAX_PUBLISHERS)
        .max_subscribers(MAX_SUBSCRIBERS)
        .open_or_create()
        .map_err(|e| err(service_name(prefix, camera, "gradients"), e))
}

fn publisher_error(service: &ServiceName, what: &str, e: PublisherCreateError) -> PublishError {
    match e {
        PublisherCreateError::ExceedsMaxSupportedPublishers => PublishError::PublisherTaken {
            service: service.to_string(),
        },
        e => err(format!("{what} publisher"), e),
    }
}

/// A publisher on a fixed-size service (refused when another process publishes on it).
pub fn publisher<T: std::fmt::Debug + ZeroCopySend>(
    svc: &PortFactory<ipc::Service, T, ()>,
    what: &str,
) -> Result<Publisher<ipc::Service, T, ()>, PublishError> {
    svc.publisher_builder()
        .create()
        .map_err(|e| publisher_error(svc.name(), what, e))
}

/// A publisher of gradient slices (grows its slices on demand).
pub(crate) fn gradients_publisher(
    svc: &PortFactory<ipc::Service, [u8], GradientsHeader>,
) -> Result<Publisher<ipc::Service, [u8], GradientsHeader>, PublishError> {
    svc.publisher_builder()
        .initial_max_slice_len(GRADIENTS_INITIAL_SLICE)
        .allocation_strategy(AllocationStrategy::PowerOfTwo)
        .create()
        .map_err(|e| publisher_error(svc.name(), "gradients", e))
}

/// A subscriber on a fixed-size service.
pub fn subscriber<T: std::fmt::Debug + ZeroCopySend>(
    svc: &PortFactory<ipc::Service, T, ()>,
    buffer: usize,
    what: &str,
) -> Result<Subscriber<ipc::Service, T, ()>, PublishError> {
    svc.subscriber_builder()
        .buffer_size(buffer)
        .create()
        .map_err(|e| err(format!("{what} subscriber"), e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_config_puts_files_under_the_root_with_our_prefix() {
        let cfg = iox_config(Path::new("/run/x/iox")).unwrap();
        assert_eq!(cfg.global.root_path().to_string(), "/run/x/iox");
        assert_eq!(
            cfg.global.prefix.to_string(),
            segment_prefix(Path::new("/run/x/iox"))
        );
        assert!(segment_prefix(Path::new("/run/x/iox")).starts_with(SHM_PREFIX));
        assert_ne!(
            segment_prefix(Path::new("/tmp/mosaicd-1000/iceoryx2")),
            segment_prefix(Path::new("/tmp/mosaicd-1001/iceoryx2")),
            "users' roots have their own segments"
        );
        assert!(matches!(
            iox_config(Path::new("rel")),
            Err(PublishError::BadRoot { .. })
        ));
    }

    /// An environment with every variable unset, `/run/mosaicd` and `/tmp` inside `base`.
    fn env(base: &Path, uid: u32) -> RootEnv {
        RootEnv {
            uid,
            runtime_directory: None,
            xdg_runtime_dir: None,
            system_dir: base.join("run-mosaicd"),
            tmp_dir: base.join("tmp"),
        }
    }

    /// A directory in `base` owned by `uid` (chown needs root; otherwise `uid` must be ours).
    fn dir_of(base: &Path, name: &str, uid: u32) -> PathBuf {
        let d = base.join(name);
        std::fs::create_dir(&d).unwrap();
        if uid != euid() {
            std::os::unix::fs::chown(&d, Some(uid), None).unwrap();
        }
        d
    }

    #[test]
    fn auto_resolves_runtime_directory_then_run_then_xdg_then_private_tmp() {
        let t = tempfile::tempdir().unwrap();
        let base = t.path();
        // A user other than root: ours when we are not root, one chown can give a directory to.
        let user = if euid() == 0 { 4242 } else { euid() };
        let auto = |e: &RootEnv| resolve_root(&Iox2Root::Auto, e);
        let tmp_root = base.join(format!("tmp/mosaicd-{user}/iceoryx2"));
        // Nothing set, not root: the private directory in /tmp, named by the uid.
        assert_eq!(auto(&env(base, user)), (tmp_root.clone(), RootOrigin::PrivateTmp));
        // Root: /run/mosaicd.
        assert_eq!(
            auto(&env(base, 0)),
            (base.join("run-mosaicd/iceoryx2"), RootOrigin::System)
        );
        // systemd's RUNTIME_DIRECTORY wins over everything, first entry only.
        for uid in [0, user] {
            let e = RootEnv {
                runtime_directory: Some("/run/mosaicd:/run/other".into()),
                xdg_runtime_dir: Some(base.as_os_str().into()),
                ..env(base, uid)
            };
            assert_eq!(
                auto(&e),
                (
                    PathBuf::from("/run/mosaicd/iceoryx2"),
                    RootOrigin::RuntimeDirectory
                )
            );
        }
        // Relative or empty variables count as unset.
        let e = RootEnv {
            runtime_directory: Some("".into()),
            xdg_runtime_dir: Some("run/user".into()),
            ..env(base, user)
        };
        assert_eq!(auto(&e), (tmp_root.clone(), RootOrigin::PrivateTmp));
        // XDG_RUNTIME_DIR: used when it is a directory of this user.
        let xdg = dir_of(base, "xdg", user);
        let with_xdg = |xdg: &Path, uid| RootEnv {
            xdg_runtime_dir: Some(xdg.as_os_str().into()),
            ..env(base, uid)
        };
        assert_eq!(
            auto(&with_xdg(&xdg, user)),
            (xdg.join("mosaicd/iceoryx2"), RootOrigin::XdgRuntimeDir)
        );
        // ... not when another user owns it, it is missing, or the root would be too long.
        assert_eq!(auto(&with_xdg(&xdg, user + 1)).1, RootOrigin::PrivateTmp);
        assert_eq!(
            auto(&with_xdg(&base.join("gone"), user)).1,
            RootOrigin::PrivateTmp
        );
        let deep = dir_of(base, &"d".repeat(250), user);
        assert_eq!(auto(&with_xdg(&deep, user)).1, RootOrigin::PrivateTmp);
        // ... and root keeps /run/mosaicd even with one.
        assert_eq!(auto(&with_xdg(&xdg, 0)).1, RootOrigin::System);
        // /run/mosaicd given to a user (the units' user, without RUNTIME_DIRECTORY): used by it.
        let sys = dir_of(base, "run-mosaicd", user);
        assert_eq!(
            auto(&with_xdg(&xdg, user)),
            (sys.join("iceoryx2"), RootOrigin::System)
        );
        assert_eq!(auto(&with_xdg(&xdg, user + 1)).1, RootOrigin::PrivateTmp);
        // A configured path is taken as it is.
        let set = Iox2Root::Path(PathBuf::from("/srv/iox"));
        assert_eq!(
            resolve_root(&set, &env(base, 0)),
            (PathBuf::from("/srv/iox"), RootOrigin::Configured)
        );
    }

    #[test]
    fn the_private_tmp_directory_is_created_0700_and_refused_when_foreign() {
        let t = tempfile::tempdir().unwrap();
        let own = t.path().join("mosaicd-own");
        prepare_private_dir(&own).unwrap();
        assert_eq!(std::fs::metadata(&own).unwrap().mode() & 0o7777, 0o700);
        std::fs::set_permissions(&own, std::fs::Permissions::from_mode(0o777)).unwrap();
        prepare_private_dir(&own).unwrap();
        assert_eq!(
            std::fs::metadata(&own).unwrap().mode() & 0o7777,
            0o700,
            "narrowed"
        );
        let file = t.path().join("mosaicd-file");
        std::fs::write(&file, "x").unwrap();
        assert!(matches!(
            prepare_private_dir(&file),
            Err(PublishError::BadRoot { .. })
        ));
        let link = t.path().join("mosaicd-link");
        std::os::unix::fs::symlink(&own, &link).unwrap();
        assert!(
            prepare_private_dir(&link).is_err(),
            "a symbolic link is not the directory"
        );
        if euid() == 0 {
            let planted = dir_of(t.path(), "mosaicd-planted", 65534);
            match prepare_private_dir(&planted) {
                Err(e @ PublishError::ForeignOwner { .. }) => {
                    assert!(e.to_string().contains("uid 65534"), "{e}")
                }
                other => panic!("a planted directory was accepted: {other:?}"),
            }
        } else {
            eprintln!("skipped the planted directory: giving it to another user needs root");
        }
    }

    #[test]
    fn max_root_len_is_the_limit_iceoryx2_checks() {
        let fits = format!("/{}", "r".repeat(MAX_ROOT_LEN - 1));
        assert!(iox_config(Path::new(&fits)).is_ok());
        let long = format!("{fits}r");
        assert!(matches!(
            iox_config(Path::new(&long)),
            Err(PublishError::BadRoot { .. })
        ));
    }

    #[test]
    fn a_missing_root_is_created_0750_and_a_second_publisher_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let root = dir.path().join("a/b");
        let node = create_node(&format!("unit-pub-{}", std::process::id()), true, &root).unwrap();
        assert_eq!(std::fs::metadata(&root).unwrap().mode() & 0o7777, 0o750);
        let prefix = format!("u{}", std::process::id());
        let svc = detections_service(&node, &prefix, "c", 4).unwrap();
        let _first = publisher(&svc, "detections").unwrap();
        match publisher(&svc, "detections") {
            Err(e @ PublishError::PublisherTaken { .. }) => {
                assert!(e.to_string().contains(&format!("{prefix}/c/detections")), "{e}")
            }
            other => panic!("second publisher: {:?}", other.map(|_| ())),
        }
        // No segment of ours is open to other users.
        for (path, meta) in our_segments(&root) {
            if path.to_string_lossy().ends_with(MGMT_SUFFIX) && meta.uid() == euid() {
                assert_eq!(meta.mode() & 0o777, MGMT_SEGMENT_MODE, "{}", path.display());
            }
        }
    }
}
