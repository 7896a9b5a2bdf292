//! Tests that run the `axisctl` binary (against the in-process bench, served
//! links on ptys, tmux, python-can): one binary, so the crate is linked once.
//! Tests that need a process of their own stay in `tests/*.rs`.

#[path = "../common/mod.rs"]
mod common;

mod address;
mod backup_cli;
mod batch_cli;
mod batch_pipeline;
mod bench_cli;
mod benchwide;
mod cdios_cli;
mod cdios_wire;
mod checked_before_sending;
mod commission;
mod completions_man;
mod dashboard_tmux;
mod decode_cli;
mod device_bench;
mod device_cdios;
mod device_flag;
mod device_pac;
mod doc_examples;
mod emergency_halt;
mod faults_cli;
mod flags_cli;
mod guide_walkthrough;
mod json_docs;
mod json_streams;
mod json_vocabulary;
mod monitor_cli;
mod multi_device_json;
mod names_cli;
mod output_failures;
mod pac_cli;
mod pac_sim;
mod plot_cli;
mod polish;
mod powercube_cli;
mod powercube_settings;
mod python_interop;
mod record_cli;
mod refusal_json;
mod shell_tmux;
mod sim_trace;
mod socketcand;
mod supervisor_cli;
mod wait_timeout_cli;
mod wire_bytes;
