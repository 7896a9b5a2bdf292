//! pac operations (see the module above).
