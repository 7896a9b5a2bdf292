//! CubeState, short state, DIO, Setup, Config and Profibus words.
