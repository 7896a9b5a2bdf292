//! One frame of a shared CAN bus as its family reads it: what kind of
//! frame it is, which module and node it names, a summary in words and
//! the decoded details. Each CAN family's `bus` module makes them from its
//! own frames; the bus decoder (`monitor`) adds whose frame it is.

/// One frame, decoded by its family.
#[derive(Debug, Clone, PartialEq)]
pub struct BusFrame {
    /// request, ack, broadcast, nmt, command, reply, event, error or raw.
    pub kind: &'static str,
    /// PowerCube module id, or Cdios module id (0..15; > 15 the controller).
    pub module: Option<u8>,
    pub node: Option<u8>,
    pub summary: String,
    /// Set when the frame is the family's but does not decode.
    pub error: Option<String>,
    pub details: serde_json::Value,
}

impl BusFrame {
    pub fn new(kind: &'static str, summary: String) -> Self {
        Self { kind, module: None, node: None, summary, error: None, details: serde_json::Value::Null }
    }
}
