//! Calling third-party code that panics on malformed input (rawloader, the `mcap` reader) with
//! its panics kept off stderr: [`call_quietly`].

use std::sync::{Arc, Mutex};

/// Serialises the panic-hook swap of [`call_quietly`].
static HOOK_SWAP: Mutex<()> = Mutex::new(());

/// Run `f` with the panics raised in the source files of a crate whose path contains
/// `in_crate` kept quiet (logged at debug level); the caller catches them (`catch_unwind`).
///
/// The process's panic hook prints "panicked at ..." before any `catch_unwind` sees the panic
/// (and a fuzzer's hook aborts). For the duration of the call (serialised by a mutex), the hook
/// is one that stays silent for panics located in that crate and hands every other panic, from
/// any thread, to the previous hook; the previous hook is restored afterwards.
pub(crate) fn call_quietly<T>(in_crate: &'static str, f: impl FnOnce() -> T) -> T {
    let _serial = HOOK_SWAP.lock().unwrap_or_else(|p| p.into_inner());
    let previous: Arc<dyn Fn(&std::panic::PanicHookInfo<'_>) + Send + Sync> =
        Arc::from(std::panic::take_hook());
    let chained = Arc::clone(&previous);
    std::panic::set_hook(Box::new(move |info| {
        if info.location().is_some_and(|l| l.file().contains(in_crate)) {
            tracing::debug!(panic = %info, "{in_crate} panicked (caught: the input is refused)");
        } else {
            chained(info);
        }
    }));
    let out = std::panic::catch_unwind(std::panic::AssertUnwindSafe(f));
    let _ = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| previous(info)));
    match out {
        Ok(v) => v,
        Err(p) => std::panic::resume_unwind(p),
    }
}
