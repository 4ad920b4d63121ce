//! iceoryx2 publishing and the `#[repr(C)]` message types subscribers read.
