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

/// Runs `cmd`'s child without address-space layout randomization (`personality(ADDR_NO_RANDOMIZE)`
/// between fork and exec, as `setarch -R` does). gmsh orders some of its work by pointer
/// addresses: with ASLR two runs on the same .geo differ in the last digit of node coordinates
/// (measured on the coarse blade: a new mesh at every run, 1e-17 relative), which a nearly
/// singular continuation can amplify (the forced curve of `tests/forced_cli.rs` stopped early on
/// one such mesh in CI); without it the mesh is the same bytes at every run.
pub fn without_aslr(cmd: &mut Command) -> &mut Command {
    #[cfg(target_os = "linux")]
    {
        use std::os::unix::process::CommandExt;
        // SAFETY: the closure runs in the forked child before exec and calls only the
        // async-signal-safe personality, allocating nothing. Best effort: where a sandbox
        // refuses the call the child runs as it would have (with ASLR).
        unsafe {
            cmd.pre_exec(|| {
                let current = libc::personality(0xffff_ffff);
                if current != -1 {
                    let wanted =
                        current as libc::c_ulong | libc::ADDR_NO_RANDOMIZE as libc::c_ulong;
                    libc::personality(wanted);
                }
                Ok(())
            });
        }
    }
    cmd
}

/// Runs `cmd`'s child at a lower scheduling priority (nice +`NICE_BESIDE`, as `nice -n` does):
/// for work that runs beside the stages on the critical path (the modes stage beside the
/// backbone) and has time to spare, so that it takes the cores they leave idle instead of
/// sharing theirs. Best effort: where the call is refused the child runs at normal priority.
pub fn at_lower_priority(cmd: &mut Command) -> &mut Command {
    #[cfg(target_os = "linux")]
    {
        use std::os::unix::process::CommandExt;
        // SAFETY: the closure runs in the forked child before exec and calls only the
        // async-signal-safe setpriority, allocating nothing.
        unsafe {
            cmd.pre_exec(|| {
                libc::setpriority(libc::PRIO_PROCESS, 0, NICE_BESIDE);
                Ok(())
            });
        }
    }
    cmd
}

/// The niceness of a child that runs beside the critical path (`at_lower_priority`).
const NICE_BESIDE: libc::c_int = 10;
