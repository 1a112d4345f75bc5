//! CiA 309-3 ASCII gateway ("ASCII mapping"): drive a CANopen network from any language with
//! text lines over TCP, a Unix socket or stdio.
//!
//! Layers:
//! * [`value`]: the data types of the mapping and their text forms.
//! * [`command`]: typed requests, responses and event lines, and the formatter back to text.
//! * [`parse`]: the nom parser from a line to a [`Request`].
//! * [`server`]: the [`Gateway`]: connections over TCP, a Unix socket, stdio or any byte
//!   stream in front of one `canopen::Network`, with one request queue per node.
//!
//! ```
//! use canopen_gateway::{Command, parse_line};
//!
//! let req = parse_line("[1] 4 read 0x1017 0 u16\r\n").unwrap().unwrap();
//! assert_eq!(req.node, Some(4));
//! assert!(matches!(req.command, Command::Read { index: 0x1017, .. }));
//! assert_eq!(req.to_string(), "[1] 4 read 0x1017 0 u16");
//! ```

pub mod command;
mod exec;
pub mod parse;
pub mod server;
pub mod value;

pub use command::{Command, ErrorCode, Event, EventKind, NmtService, Reply, Request, Response};
pub use parse::{ParseError, parse_line};
pub use server::{Config, Gateway, Version};
pub use value::{DataType, Value};
