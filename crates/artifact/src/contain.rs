//! Containing a dependency's panic on malformed input.
//!
//! Some parsing libraries panic on input they cannot handle (the generative tests found
//! `gltf-json` indexing past its arrays and unwrapping invalid items while *validating*
//! a damaged file). Such a panic is the library's defect, but the file is the user's:
//! [`contain`] runs the library call and turns its panic into an error message, and
//! [`is_contained`] tells the stage's panic hook (`reprise_stagekit::panic`) not to print
//! an "internal error" for it.

use std::cell::Cell;

thread_local! {
    static DEPTH: Cell<u32> = const { Cell::new(0) };
}

/// Runs `f`; a panic inside it becomes `Err` with the panic's message.
pub fn contain<T>(f: impl FnOnce() -> T) -> Result<T, String> {
    DEPTH.with(|d| d.set(d.get() + 1));
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(f));
    DEPTH.with(|d| d.set(d.get() - 1));
    result.map_err(|p| {
        p.downcast_ref::<&str>()
            .map(|s| (*s).to_string())
            .or_else(|| p.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "(no message)".into())
    })
}

/// Whether this thread is inside [`contain`] (a panic here is handled by the caller).
pub fn is_contained() -> bool {
    DEPTH.with(Cell::get) > 0
}

#[cfg(test)]
mod tests {
    /// A contained panic is an error with its message; the flag is set only inside.
    #[test]
    fn a_panic_becomes_an_error() {
        assert_eq!(super::contain(|| 3), Ok(3));
        let e = super::contain(|| -> u8 {
            assert!(super::is_contained());
            panic!("bad index {}", 7)
        });
        assert_eq!(e, Err("bad index 7".into()));
        assert!(!super::is_contained());
    }
}
