//! PowerCube RS232 framing (manual 4.3): STX, TELID, data, BCC, ETX with DLE
//! escaping. Filled in by the RS232 work.
