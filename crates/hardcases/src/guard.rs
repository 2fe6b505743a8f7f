//! Catching panics quietly: a panic inside [`catch_quiet`] becomes an `Err` with the panic
//! message and location, and is not printed (other panics are printed as usual).

use std::cell::{Cell, RefCell};
use std::panic::{self, AssertUnwindSafe};
use std::sync::Once;

thread_local! {
    static QUIET: Cell<u32> = const { Cell::new(0) };
    static LAST: RefCell<Option<String>> = const { RefCell::new(None) };
}

static INSTALL: Once = Once::new();

fn install_hook() {
    INSTALL.call_once(|| {
        let previous = panic::take_hook();
        panic::set_hook(Box::new(move |info| {
            if QUIET.with(|q| q.get()) > 0 {
                let msg = payload_message(info.payload());
                let text = match info.location() {
                    Some(l) => format!("panic at {}:{}: {msg}", l.file(), l.line()),
                    None => format!("panic: {msg}"),
                };
                LAST.with(|last| *last.borrow_mut() = Some(text));
            } else {
                previous(info);
            }
        }));
    });
}

fn payload_message(p: &(dyn std::any::Any + Send)) -> String {
    p.downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| p.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "(non-string panic payload)".to_string())
}

/// Runs `f`, turning a panic into `Err("panic at file:line: message")`.
///
/// A panic on this thread is not printed; a panic on another thread that `f` waits for (a
/// rayon worker) is printed by the default hook and its message is returned.
pub fn catch_quiet<R>(f: impl FnOnce() -> R) -> Result<R, String> {
    install_hook();
    QUIET.with(|q| q.set(q.get() + 1));
    LAST.with(|l| l.borrow_mut().take());
    let r = panic::catch_unwind(AssertUnwindSafe(f));
    QUIET.with(|q| q.set(q.get() - 1));
    r.map_err(|p| {
        LAST.with(|l| l.borrow_mut().take())
            .unwrap_or_else(|| format!("panic: {}", payload_message(p.as_ref())))
    })
}
