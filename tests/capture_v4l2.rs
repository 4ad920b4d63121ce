//! V4L2 source errors on this machine (no camera): a missing device and a node that is not a
//! camera both give clear errors, never a panic.

use mosaicd::capture::CaptureError;
use mosaicd::capture::{V4l2Options, V4l2Source};

#[test]
fn missing_device_is_a_clear_error() {
    let path = "/dev/video0";
    if std::path::Path::new(path).exists() {
        // A real camera is attached: the missing-device case is checked on a name that cannot exist.
        let e = V4l2Source::open("/dev/video-mosaicd-absent", V4l2Options::default()).unwrap_err();
        assert!(matches!(e, CaptureError::DeviceMissing { .. }), "{e}");
        return;
    }
    let e = V4l2Source::open(path, V4l2Options::default()).unwrap_err();
    let msg = e.to_string();
    assert!(matches!(e, CaptureError::DeviceMissing { .. }), "{msg}");
    assert!(
        msg.contains("/dev/video0") && msg.contains("does not exist"),
        "{msg}"
    );
}

#[test]
fn a_node_that_is_not_a_camera_is_refused() {
    let e = V4l2Source::open("/dev/null", V4l2Options::default()).unwrap_err();
    let msg = e.to_string();
    assert!(
        msg.contains("/dev/null") && msg.contains("not a V4L2 device"),
        "{msg}"
    );
}

#[test]
fn zero_buffers_is_refused_by_name() {
    let opts = V4l2Options {
        buffers: 0,
        ..Default::default()
    };
    let e = V4l2Source::open("/dev/null", opts).unwrap_err();
    assert!(e.to_string().contains("buffers"), "{e}");
}
