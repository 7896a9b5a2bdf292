//! cdios operations (see the module above).
