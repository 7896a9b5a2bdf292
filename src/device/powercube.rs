//! powercube operations (see the module above).
