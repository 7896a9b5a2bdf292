//! The Lawicel / slcan ASCII protocol, sans-IO.
