//! The dead-man backstop: while a supervised motion lasts, the process that
//! waits for it keeps the module watchdog refreshed (the session sends the
//! refresh from every exchange and every pause, see
//! `session::powercube::refresh`). If the process dies (SIGKILL, power,
//! a pulled USB adapter), the refreshes stop and every module whose
//! watchdog is online halts 50 ms after the last one, with STATE_COMM_ERROR
//! (manual 13). The refresh goes on through the halt of a failed wait and
//! stops once the motion is over: a module left with an online watchdog
//! then halts 50 ms later unless something else keeps it alive.

use std::time::Duration;

use super::{ConfigChange, Cubes, Error};
use crate::proto::powercube::flags::config;
use crate::proto::powercube::table::ids;
use crate::proto::powercube::{ModuleId, Request};

/// How a supervised motion treats the module watchdog.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Deadman {
    /// Refresh while the motion lasts when a moved module has
    /// CONFIGID_MOD_WATCHDOG_ENABLE (its watchdog is on, see
    /// [`Cubes::watchdog_on`]); otherwise nothing is sent.
    #[default]
    Auto,
    /// `--deadman`: as `Auto`, and a moved module whose watchdog is off has
    /// it switched on for this motion and off again afterwards.
    Arm,
}

/// Refresh period: well inside the manual's 50 ms, with room for a late
/// turn of the scheduler on a loaded host.
pub const REFRESH_EVERY: Duration = Duration::from_millis(20);

/// What a supervised motion set up, undone by [`Cubes::release_deadman`].
#[derive(Debug, Default)]
pub(super) struct Armed {
    /// Modules whose watchdog `Arm` switched on: switched off afterwards.
    switched_on: Vec<ModuleId>,
}

impl Cubes {
    /// The watchdog policy of the supervised motions sent from here on.
    /// `Arm` is refused on RS232 (the refresh is a CAN broadcast) before
    /// anything is sent.
    pub fn set_deadman(&mut self, d: Deadman) -> Result<(), Error> {
        if d == Deadman::Arm {
            self.require_can_for_watchdog().map_err(|e| Error::Refused(format!("--deadman: {e}; nothing was sent")))?;
        }
        self.deadman = d;
        Ok(())
    }

    /// Right before the first motion frame of a supervised motion of
    /// `modules`, once every check has passed: reads each module's Config
    /// unless the checks read it already (`Some`, no second read);
    /// with `Arm` sets CONFIGID_MOD_WATCHDOG_ENABLE where it is clear (read
    /// back) and then switches those watchdogs online (0x07); the refresh
    /// starts once a watchdog is on, and a failure switches off what was
    /// switched on: no motion goes out.
    pub(super) fn arm_deadman(&mut self, modules: &[(ModuleId, Option<u32>)]) -> Result<(), Error> {
        if self.armed.is_some() || !self.pc.is_can() {
            return Ok(());
        }
        let mut enabled = false;
        let mut off = Vec::new();
        for &(m, known) in modules {
            let word = match known {
                Some(w) => w,
                None => self.get_u32(m, ids::CONFIG)?,
            };
            if word & config::WATCHDOG_ENABLE != 0 {
                enabled = true;
            } else if self.deadman == Deadman::Arm {
                off.push(m);
            }
        }
        let mut armed = Armed::default();
        // The toggles first: a refresh of ours must not reach a module
        // between its flag and its 0x07 (see `switch_on`). A watchdog that
        // was on already is kept alive by whoever switched it on until then,
        // or has tripped, and the module was refused as not ready.
        let on = (|| {
            self.switch_on(&off, &mut armed)?;
            if enabled && !self.pc.refreshing() {
                self.pc.start_refresh(REFRESH_EVERY)?;
            }
            Ok(())
        })();
        if let Err(e) = on {
            // Best effort: the error that stopped the motion is the one to tell.
            let _ = self.switch_off(&armed.switched_on);
            self.pc.stop_refresh();
            return Err(e);
        }
        self.armed = Some(armed);
        Ok(())
    }

    /// The flags first, then every 0x07 in one burst, and the refresh from
    /// right after it: the acknowledges may be slow, the watchdogs are
    /// online from the moment each 0x07 arrives. Our refreshes leave behind
    /// the 0x07s, so each toggle finds its watchdog offline, as it must
    /// (a refresh reaching a module whose flag is set may well switch its
    /// watchdog online: the manual calls it "activated automatically by
    /// the first life sign", and a toggle would then switch it off). The
    /// toggles are never sent twice.
    fn switch_on(&mut self, modules: &[ModuleId], armed: &mut Armed) -> Result<(), Error> {
        if modules.is_empty() {
            return Ok(());
        }
        for &m in modules {
            armed.switched_on.push(m);
            self.write_config(m, ConfigChange { set: config::WATCHDOG_ENABLE, ..ConfigChange::default() })?;
        }
        let toggles: Vec<_> = modules.iter().map(|m| (*m, Request::Watchdog)).collect();
        let burst = self.pc.send_burst(&toggles)?;
        if !self.pc.refreshing() {
            if let Err(e) = self.pc.start_refresh(REFRESH_EVERY) {
                self.pc.abandon(burst);
                return Err(e.into());
            }
        }
        for answer in self.pc.collect(burst)?.answers {
            answer?;
        }
        Ok(())
    }

    /// Clears the flag of each module (read back), which takes its watchdog
    /// offline; no 0x07 (see [`Cubes::watchdog_off`]). Every module is tried.
    fn switch_off(&mut self, modules: &[ModuleId]) -> Result<(), Error> {
        let mut first = None;
        for &m in modules {
            let clear = ConfigChange { clear: config::WATCHDOG_ENABLE, ..ConfigChange::default() };
            if let Err(e) = self.write_config(m, clear) {
                first.get_or_insert(Error::WatchdogLeftOn { module: m, source: Box::new(e) });
            }
        }
        first.map_or(Ok(()), Err)
    }

    /// After a supervised motion, whichever way it ended (its halt already
    /// sent): switches off the watchdogs `Arm` switched on, then stops the
    /// refresh. A watchdog that cannot be switched off is an error; the
    /// refresh stops all the same, so that watchdog halts the module 50 ms
    /// later (the link is likely lost: the backstop is what is left).
    pub fn release_deadman(&mut self) -> Result<(), Error> {
        let Some(armed) = self.armed.take() else { return Ok(()) };
        let off = self.switch_off(&armed.switched_on);
        self.pc.stop_refresh();
        off
    }

    /// What stops a module whose halt could not be sent (`failed`, the
    /// reason; a lost link, say, a remote one most of all): its watchdog,
    /// if this motion refreshes it, else nothing, said plainly.
    pub(super) fn backstop(&self, failed: String) -> String {
        if self.deadman_refreshing() {
            format!("{failed}; its watchdog halts it 50 ms after the last refresh (dead-man)")
        } else {
            format!("{failed}; THE MODULE MAY STILL MOVE: no watchdog was refreshed (--deadman arms one)")
        }
    }

    /// Whether the refresh of a supervised motion is going on.
    pub fn deadman_refreshing(&self) -> bool {
        self.pc.refreshing()
    }
}

#[cfg(test)]
mod tests;
