//! Files in and out: inputs read with errors that name the file and the line ([`read_text`],
//! [`parse_toml`]), outputs that never leave a half-written file behind and appear together
//! or not at all ([`write_atomic`], [`all_or_nothing`]), and JSON numbers that may be
//! infinite ([`json_number`]).

pub mod json_number;
mod read;
mod write;

pub use read::{key_lines, line_of, parse_toml, read_capped, read_text, without_bom};
pub use write::{
    AtomicWriter, PendingHeld, abandon, all_or_nothing, create_dir_all, discard_pending,
    discarded_outputs, is_standard_output, kept_outputs, output_file, staged_bytes, write_atomic,
};
