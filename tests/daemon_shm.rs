//! The daemon's iceoryx2 root and who may publish: the root comes from `publish.root` (never from
//! a `config/iceoryx2.toml` in the working directory), is created 0750, the shared management
//! segment is narrowed to 0600, a root of another user is refused in one clear line, and a second
//! publisher on a running daemon's service is refused while `mosaicd listen` keeps working, and a
//! subscriber gets a whole replay, final stats included, however late it polls while the daemon ends.

use std::io::{BufReader, Read};
use std::os::unix::fs::{MetadataExt, PermissionsExt};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStderr, Command, Stdio};
use std::time::{Duration, Instant};

use mosaicd::publish::{create_node, detections_service, publisher, segment_prefix, PublishError};

mod common;

const BIN: &str = env!("CARGO_BIN_EXE_mosaicd");

fn unique(tag: &str) -> String {
    format!("t{}{tag}", std::process::id())
}

fn config(dir: &Path, root: &Path, prefix: &str, camera: &str, frames: &str) -> PathBuf {
    let p = dir.join(format!("{camera}.toml"));
    std::fs::write(
        &p,
        format!(
            "[daemon]\nthreads = 1\nstats_interval_ms = 200\n[compute]\ndetect = false\n\
             [publish]\nservice_prefix = \"{prefix}\"\nroot = {root:?}\nsubscriber_buffer = 256\n\
             [[camera]]\nname = \"{camera}\"\nsource = \"synthetic\"\nwidth = 32\nheight = 32\n{frames}\n"
        ),
    )
    .unwrap();
    p
}

/// `mosaicd listen` on `root` for the camera, with `until` (when to stop), once subscribed.
fn listen(root: &Path, prefix: &str, camera: &str, until: &[&str]) -> Child {
    listen_with_stderr(root, prefix, camera, until).0
}

/// As [`listen`], with the reader of the listener's stderr after its "subscribed" line.
fn listen_with_stderr(
    root: &Path,
    prefix: &str,
    camera: &str,
    until: &[&str],
) -> (Child, BufReader<ChildStderr>) {
    let root = root.to_str().unwrap();
    let mut args = vec![
        "--camera", camera, "--prefix", prefix, "--root", root, "--buffer", "256",
    ];
    args.extend_from_slice(until);
    common::spawn_listener_with_stderr(BIN, &args)
}

/// `mosaicd run --config cfg` in the background (stderr piped).
fn spawn_daemon(cfg: &Path) -> Child {
    Command::new(BIN)
        .args(["run", "--config"])
        .arg(cfg)
        .env("RUST_LOG", "warn")
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

/// The detections messages and final stats messages in a listener's output.
fn detections_and_finals(stdout: &[u8]) -> (usize, usize) {
    let out = String::from_utf8_lossy(stdout);
    let detections = out
        .lines()
        .filter(|l| l.contains("\"topic\":\"detections\""))
        .count();
    let finals = out
        .lines()
        .filter(|l| l.contains("\"topic\":\"stats\"") && l.contains("\"is_final\":1"))
        .count();
    (detections, finals)
}

/// Send `sig` to our child `c`.
fn signal(c: &Child, sig: libc::c_int) {
    // SAFETY: plain kill(2) on our own child's pid.
    assert_eq!(unsafe { libc::kill(c.id() as i32, sig) }, 0);
}

/// `mosaicd run --config cfg`, which must fail; its stderr.
fn refused(cfg: &Path) -> String {
    let out = Command::new(BIN)
        .args(["run", "--config"])
        .arg(cfg)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(!out.status.success(), "{} started: {err}", cfg.display());
    err
}

fn mode(p: &Path) -> u32 {
    std::fs::metadata(p).unwrap().permissions().mode() & 0o7777
}

#[test]
fn the_root_comes_from_the_config_not_the_working_directory_and_listen_follows_it() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("run/iox");
    let (prefix, camera) = (unique("rp"), unique("rc"));
    // At full speed: the replay ends within milliseconds, and the daemon keeps its publishers until
    // the listener has the final stats (see
    // `a_subscriber_that_polls_only_after_the_replay_still_receives_all_of_it`).
    let cfg = config(dir.path(), &root, &prefix, &camera, "frames = 20");
    // A config file iceoryx2 would read first from the working directory: it must be ignored.
    let decoy = dir.path().join("decoy-root");
    std::fs::create_dir_all(dir.path().join("config")).unwrap();
    std::fs::write(
        dir.path().join("config/iceoryx2.toml"),
        format!("[global]\nroot-path = {:?}\nprefix = \"decoy_\"\n", decoy),
    )
    .unwrap();
    let listener = listen(&root, &prefix, &camera, &["--until-final", "--timeout-s", "60"]);
    let out = Command::new(BIN)
        .args(["run", "--config"])
        .arg(&cfg)
        .current_dir(dir.path())
        .env("RUST_LOG", "warn")
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let lout = listener.wait_with_output().unwrap();
    assert!(lout.status.success(), "{}", String::from_utf8_lossy(&lout.stderr));
    let n = String::from_utf8_lossy(&lout.stdout)
        .lines()
        .filter(|l| l.contains("\"topic\":\"detections\""))
        .count();
    assert_eq!(n, 20, "listen --root received every frame");
    assert!(
        !decoy.exists(),
        "the working directory's config/iceoryx2.toml was read"
    );
    assert_eq!(mode(&root), 0o750, "the root is created 0750");
    // iceoryx2 creates its management segment 0666 for every user: narrowed to the owner.
    let shm_prefix = segment_prefix(&root);
    let mgmt: Vec<PathBuf> = std::fs::read_dir("/dev/shm")
        .unwrap()
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| {
            let n = p.file_name().unwrap().to_string_lossy();
            n.starts_with(&shm_prefix) && n.ends_with(".global_mgmt")
        })
        .collect();
    assert!(
        !mgmt.is_empty(),
        "no {shm_prefix}*.global_mgmt segment in /dev/shm"
    );
    for m in mgmt {
        assert_eq!(mode(&m) & 0o066, 0, "{} is open to others", m.display());
    }
}

#[test]
fn a_root_that_is_a_file_or_relative_is_refused_in_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("not-a-dir");
    std::fs::write(&file, "x").unwrap();
    let (prefix, camera) = (unique("fp"), unique("fc"));
    let cfg = config(dir.path(), &file, &prefix, &camera, "frames = 2");
    let err = refused(&cfg);
    assert!(
        err.contains("not-a-dir") && err.contains("is not a directory"),
        "{err}"
    );
    assert_eq!(
        err.matches("is not a directory").count(),
        1,
        "printed once: {err}"
    );
    let rel = dir.path().join("rel.toml");
    std::fs::write(
        &rel,
        "[publish]\nroot = \"iox\"\n[[camera]]\nname = \"a\"\nsource = \"synthetic\"\n",
    )
    .unwrap();
    let err = refused(&rel);
    assert!(err.contains("publish.root"), "{err}");
}

#[test]
fn a_root_another_user_created_is_refused_naming_path_and_owner() {
    // SAFETY: geteuid has no preconditions.
    if unsafe { libc::geteuid() } != 0 {
        eprintln!("skipped: giving a directory to another user (chown) needs root");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("foreign");
    std::fs::create_dir(&root).unwrap();
    std::fs::set_permissions(&root, std::fs::Permissions::from_mode(0o755)).unwrap();
    let c = std::ffi::CString::new(root.to_str().unwrap()).unwrap();
    // SAFETY: a valid NUL-terminated path; uid/gid 65534 is "nobody".
    assert_eq!(unsafe { libc::chown(c.as_ptr(), 65534, 65534) }, 0);
    let (prefix, camera) = (unique("op"), unique("oc"));
    let cfg = config(dir.path(), &root, &prefix, &camera, "frames = 2");
    let err = refused(&cfg);
    let line = err
        .lines()
        .find(|l| l.contains("belongs to"))
        .unwrap_or_else(|| panic!("{err}"));
    assert!(
        line.contains(root.to_str().unwrap()) && line.contains("uid 65534"),
        "{line}"
    );
    assert_eq!(err.matches("belongs to").count(), 1, "printed once: {err}");
    assert!(!err.contains("NodeCreationFailure"), "{err}");
    // Left alone: the daemon did not take over or write into the foreign directory.
    assert_eq!(std::fs::metadata(&root).unwrap().uid(), 65534);
    assert_eq!(std::fs::read_dir(&root).unwrap().count(), 0);
}

#[test]
fn only_the_daemon_publishes_a_second_publisher_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("iox");
    let (prefix, camera) = (unique("pp"), unique("pc"));
    let cfg = config(dir.path(), &root, &prefix, &camera, "live = true\nfps = 50");
    let mut daemon = spawn_daemon(&cfg);
    // Once a listener receives, the daemon's publishers exist.
    let listener = listen(&root, &prefix, &camera, &["--count", "3", "--timeout-s", "30"]);
    let lout = listener.wait_with_output().unwrap();
    assert!(lout.status.success(), "{}", String::from_utf8_lossy(&lout.stderr));
    let node = create_node(&unique("intruder"), false, &root).unwrap();
    let svc = detections_service(&node, &prefix, &camera, 256).unwrap();
    match publisher(&svc, "detections") {
        Err(PublishError::PublisherTaken { service }) => {
            assert!(service.contains(&camera), "{service}")
        }
        Err(e) => panic!("refused, but not as taken: {e}"),
        Ok(_) => panic!("a second publisher was admitted on the daemon's service"),
    }
    drop(svc);
    drop(node);
    // SAFETY: plain kill(2) on our own child's pid.
    unsafe { libc::kill(daemon.id() as i32, libc::SIGTERM) };
    let start = std::time::Instant::now();
    while daemon.try_wait().unwrap().is_none() {
        assert!(start.elapsed() < Duration::from_secs(20), "daemon did not stop");
        std::thread::sleep(Duration::from_millis(20));
    }
    assert!(daemon.wait().unwrap().success());
}

#[test]
fn another_user_can_neither_subscribe_nor_publish() {
    use std::os::unix::process::CommandExt;
    // SAFETY: geteuid has no preconditions.
    if unsafe { libc::geteuid() } != 0 {
        eprintln!("skipped: running a process as another user (nobody) needs root");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    // Only the root's own mode keeps "nobody" out, not the test's private temporary directory.
    std::fs::set_permissions(dir.path(), std::fs::Permissions::from_mode(0o755)).unwrap();
    let root = dir.path().join("iox");
    let (prefix, camera) = (unique("np"), unique("nc"));
    let cfg = config(dir.path(), &root, &prefix, &camera, "live = true\nfps = 50");
    std::fs::set_permissions(&cfg, std::fs::Permissions::from_mode(0o644)).unwrap();
    let mut daemon = Command::new(BIN)
        .args(["run", "--config"])
        .arg(&cfg)
        .env("RUST_LOG", "warn")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let lout = listen(&root, &prefix, &camera, &["--count", "3", "--timeout-s", "30"])
        .wait_with_output()
        .unwrap();
    assert!(lout.status.success(), "the daemon's user subscribes");
    let root_s = root.to_str().unwrap();
    let as_nobody = |args: &[&str]| {
        let out = Command::new(BIN)
            .args(args)
            .uid(65534)
            .gid(65534)
            .env("RUST_LOG", "warn")
            .output()
            .unwrap();
        assert!(!out.status.success(), "nobody was let in: {args:?}");
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    let args = [
        "listen",
        "--camera",
        &camera,
        "--prefix",
        &prefix,
        "--root",
        root_s,
        "--count",
        "1",
        "--timeout-s",
        "5",
    ];
    let err = as_nobody(&args);
    assert!(err.contains("subscribers run as the daemon's user"), "{err}");
    let err = as_nobody(&["run", "--config", cfg.to_str().unwrap()]);
    assert!(err.contains("belongs to root (uid 0)"), "{err}");
    // SAFETY: plain kill(2) on our own child's pid.
    unsafe { libc::kill(daemon.id() as i32, libc::SIGTERM) };
    assert!(daemon.wait().unwrap().success());
}

/// `mosaicd run` and `mosaicd listen` with `publish.root` and `--root` left at `"auto"`, as an
/// ordinary user on a box where nobody prepared `/run/mosaicd` (the README quick start): they find
/// each other. Run as root, the test runs both as `nobody` with an empty environment (no
/// `XDG_RUNTIME_DIR`, no `RUNTIME_DIRECTORY`), so the root is `/tmp/mosaicd-65534/iceoryx2`;
/// otherwise as this user without `RUNTIME_DIRECTORY`.
#[test]
fn an_ordinary_user_publishes_and_listens_with_the_default_root() {
    use std::io::{BufRead, BufReader};
    use std::os::unix::process::CommandExt;
    // SAFETY: geteuid has no preconditions.
    let as_root = unsafe { libc::geteuid() } == 0;
    let dir = tempfile::tempdir().unwrap();
    let (prefix, camera) = (unique("ap"), unique("ac"));
    let cfg = dir.path().join("auto.toml");
    std::fs::write(
        &cfg,
        format!(
            "[daemon]\nthreads = 1\nstats_interval_ms = 200\n[compute]\ndetect = false\n\
             [publish]\nservice_prefix = \"{prefix}\"\nsubscriber_buffer = 256\n\
             [[camera]]\nname = \"{camera}\"\nsource = \"synthetic\"\nwidth = 32\nheight = 32\nframes = 20\n"
        ),
    )
    .unwrap();
    // At full speed, as in `the_root_comes_from_the_config_not_the_working_directory_and_listen_follows_it`.
    let user = |c: &mut Command| {
        if as_root {
            std::fs::set_permissions(dir.path(), std::fs::Permissions::from_mode(0o755)).unwrap();
            std::fs::set_permissions(&cfg, std::fs::Permissions::from_mode(0o644)).unwrap();
            c.uid(65534).gid(65534).env_clear();
        } else {
            c.env_remove("RUNTIME_DIRECTORY");
        }
        c.env("RUST_LOG", "warn");
    };
    let mut lc = Command::new(BIN);
    lc.args(["listen", "--camera", &camera, "--prefix", &prefix])
        .args(["--buffer", "256", "--until-final", "--timeout-s", "60"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    user(&mut lc);
    let mut listener = lc.spawn().unwrap();
    let mut err = BufReader::new(listener.stderr.take().unwrap());
    let mut line = String::new();
    while err.read_line(&mut line).unwrap() > 0 && !line.contains("subscribed") {
        line.clear();
    }
    assert!(line.contains("subscribed"), "listener did not start: {line}");
    let mut dc = Command::new(BIN);
    dc.args(["run", "--config"]).arg(&cfg);
    user(&mut dc);
    let out = dc.output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let lout = listener.wait_with_output().unwrap();
    assert!(lout.status.success(), "listener failed");
    let n = String::from_utf8_lossy(&lout.stdout)
        .lines()
        .filter(|l| l.contains("\"topic\":\"detections\""))
        .count();
    assert_eq!(n, 20, "the listener without --root received every frame ({line})");
    if as_root {
        let private = Path::new("/tmp/mosaicd-65534");
        assert!(
            line.trim_end().ends_with("under /tmp/mosaicd-65534/iceoryx2"),
            "{line}"
        );
        let meta = std::fs::symlink_metadata(private).unwrap();
        assert!(meta.is_dir() && meta.uid() == 65534, "{}", private.display());
        assert_eq!(mode(private), 0o700, "{} is private", private.display());
        assert_eq!(mode(&private.join("iceoryx2")), 0o750);
    }
}

/// A subscriber that was subscribed for the whole run receives the whole replay and the final
/// stats even when it did not poll while the daemon published (stopped with SIGSTOP here, as a
/// loaded machine can leave it unscheduled for the few milliseconds a 20-frame 32x32 replay takes).
/// iceoryx2 connects a subscriber to a publisher only in the subscriber's own `receive`, and only
/// while the publisher exists; a publisher dropped before that removes what it had queued for the
/// subscriber. So the daemon keeps its publishers after the final stats while a subscriber is
/// still subscribed, up to `FINAL_LINGER` (`IceoryxSink::finish`). Before, the daemon exited within
/// milliseconds and the continued listener received nothing (it even exited with success: the
/// SIGCONT cut its sleep short and `listen` took that for SIGINT).
#[test]
fn a_subscriber_that_polls_only_after_the_replay_still_receives_all_of_it() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("iox");
    let (prefix, camera) = (unique("lp"), unique("lc"));
    let cfg = config(dir.path(), &root, &prefix, &camera, "frames = 20");
    let (late, mut late_err) =
        listen_with_stderr(&root, &prefix, &camera, &["--until-final", "--timeout-s", "20"]);
    signal(&late, libc::SIGSTOP);
    // A second listener that polls all along tells when the daemon has sent its final stats.
    let prompt = listen(&root, &prefix, &camera, &["--until-final", "--timeout-s", "60"]);
    let mut daemon = spawn_daemon(&cfg);
    let pout = prompt.wait_with_output().unwrap();
    assert!(pout.status.success(), "the prompt listener failed");
    assert_eq!(
        detections_and_finals(&pout.stdout),
        (20, 1),
        "the prompt listener"
    );
    // The final stats are out: a daemon that does not linger is gone within milliseconds (its
    // publishers right after the final stats); one that does waits for the stopped listener.
    let start = Instant::now();
    while daemon.try_wait().unwrap().is_none() && start.elapsed() < Duration::from_millis(50) {
        std::thread::sleep(Duration::from_millis(2));
    }
    signal(&late, libc::SIGCONT);
    let lout = late.wait_with_output().unwrap();
    let mut lerr = String::new();
    late_err.read_to_string(&mut lerr).unwrap();
    let dout = daemon.wait_with_output().unwrap();
    assert!(dout.status.success(), "{}", String::from_utf8_lossy(&dout.stderr));
    assert!(lout.status.success(), "the late listener failed: {lerr}");
    assert_eq!(
        detections_and_finals(&lout.stdout),
        (20, 1),
        "the late listener received every frame and the final stats ({lerr})"
    );
}
