//! Ctrl-C (SIGINT), SIGTERM and SIGHUP: the command ends by the signal, as it would without
//! robocal doing anything, but first deletes the temporary files of the outputs it had not yet
//! put in place and the folders it made ([`robocal::io::discard_pending`]), so an interrupted
//! `simulate` of a million rows or `train --plot new/folder` leaves nothing behind.
//!
//! The signals are blocked in every thread and taken by one thread of their own with
//! `sigwait`, where the clean-up may lock and delete (nothing of it would be safe in a signal
//! handler). That thread then restores the signal's default action and raises it again: the
//! process ends killed by it, so a shell loop stops at Ctrl-C and sees 130 (143 for SIGTERM,
//! 129 for SIGHUP). A signal ignored when robocal starts (`nohup`, a background job of a
//! script) stays ignored. Nothing is printed: standard error may be a full pipe, and a shell
//! says what ended its job.

/// Takes SIGINT, SIGTERM and SIGHUP (those not ignored at start-up) on a thread of their own
/// (module doc). Call it first in `main`, before any other thread exists: threads inherit the
/// blocked set from the one that starts them.
#[cfg(unix)]
pub fn clean_up_on_interrupt() {
    // SAFETY: sigset_t and sigaction are plain C structs, valid all-zero and filled by
    // sigemptyset and sigaction; the calls get valid pointers to them and no other thread
    // exists yet to race on the signal mask.
    let set = unsafe {
        let mut set: libc::sigset_t = std::mem::zeroed();
        libc::sigemptyset(&mut set);
        let mut any = false;
        for sig in [libc::SIGINT, libc::SIGTERM, libc::SIGHUP] {
            let mut old: libc::sigaction = std::mem::zeroed();
            if libc::sigaction(sig, std::ptr::null(), &mut old) == 0
                && old.sa_sigaction != libc::SIG_IGN
            {
                libc::sigaddset(&mut set, sig);
                any = true;
            }
        }
        if !any || libc::pthread_sigmask(libc::SIG_BLOCK, &set, std::ptr::null_mut()) != 0 {
            return;
        }
        set
    };
    let started = std::thread::Builder::new()
        .name("interrupt".into())
        .spawn(move || {
            let mut sig = 0;
            // SAFETY: `set` is a valid signal set and `sig` a valid place for the number.
            if unsafe { libc::sigwait(&set, &mut sig) } != 0 {
                return;
            }
            // Held to the end: no output is put in place after the clean-up.
            let _held = robocal::io::discard_pending();
            // SAFETY: plain calls on a valid signal number and a set built as above.
            unsafe {
                libc::signal(sig, libc::SIG_DFL);
                let mut one: libc::sigset_t = std::mem::zeroed();
                libc::sigemptyset(&mut one);
                libc::sigaddset(&mut one, sig);
                libc::pthread_sigmask(libc::SIG_UNBLOCK, &one, std::ptr::null_mut());
                libc::raise(sig);
            }
            // Not reached (the default action ends the process), but should it be: the
            // shell's code for the signal, the pending list still held.
            std::process::exit(128 + sig);
        });
    if started.is_err() {
        // Without the thread no one would take the signals: let them act as before.
        // SAFETY: as above.
        unsafe {
            libc::pthread_sigmask(libc::SIG_UNBLOCK, &set, std::ptr::null_mut());
        }
    }
}

/// Elsewhere the signals act as the system has them.
#[cfg(not(unix))]
pub fn clean_up_on_interrupt() {}
