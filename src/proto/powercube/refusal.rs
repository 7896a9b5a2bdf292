//! The PowerCube's refusal (its CubeState carries error flags), as data for
//! [`Refusal`].

use std::fmt;

use serde::Serialize;

use super::flags::CUBE_STATE;
use crate::proto::Refusal;

#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct PowerCubeRefusal {
    /// The CubeState word as read.
    pub cube_state: u32,
    /// Its set flags that the manual marks as errors, by name.
    pub errors: Vec<&'static str>,
}

impl Refusal {
    /// A PowerCube module whose CubeState carries errors.
    pub fn powercube(cube_state: u32) -> Self {
        Self::PowerCube(PowerCubeRefusal { cube_state, errors: CUBE_STATE.decode(cube_state).errors })
    }
}

impl fmt::Display for PowerCubeRefusal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "CubeState {:#010x}", self.cube_state)?;
        if !self.errors.is_empty() {
            write!(f, " ({})", self.errors.join(", "))?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn powercube_refusal_lists_error_flags() {
        use crate::proto::powercube::flags::state;
        let r = Refusal::powercube(state::ERROR | state::POWERFAULT | state::HOME_OK);
        let Refusal::PowerCube(p) = &r else { panic!() };
        assert_eq!(p.errors, ["STATE_ERROR", "STATE_POWERFAULT"]);
        assert_eq!(r.to_string(), "CubeState 0x0000000b (STATE_ERROR, STATE_POWERFAULT)");
        assert_eq!(serde_json::to_value(&r).unwrap()["family"], "powercube");
        assert_eq!(serde_json::to_value(&r).unwrap()["cube_state"], 11);
    }
}
