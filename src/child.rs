//! Child processes (gmsh, the `modes` stage) that die with `nlmodes`: on Linux each child asks
//! the kernel for SIGKILL when its parent dies (`prctl(PR_SET_PDEATHSIG)` between fork and exec),
//! so even a SIGKILL of `nlmodes` leaves no gmsh or eigensolver running.

use std::process::Command;

/// Makes `cmd`'s child receive SIGKILL when this process dies. The signal follows the thread
/// that spawned the child: call from the main thread (as every stage does).
pub fn die_with_parent(cmd: &mut Command) -> &mut Command {
    #[cfg(target_os = "linux")]
    {
        use std::os::unix::process::CommandExt;
        let parent = std::process::id() as libc::pid_t;
        // SAFETY: the closure runs in the forked child before exec and calls only the
        // async-signal-safe prctl and getppid, allocating nothing.
        unsafe {
            cmd.pre_exec(move || {
                if libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGKILL, 0, 0, 0) != 0 {
                    return Err(std::io::Error::last_os_error());
                }
                // The parent may have died between fork and prctl: then it is already gone.
                if libc::getppid() != parent {
                    return Err(std::io::Error::other("the parent process exited"));
                }
                Ok(())
            });
        }
    }
    cmd
}
