//! Tests of the library and of the source tree that need no binary.

mod architecture;
mod faults;
mod tables_doc;
mod test_commands;
