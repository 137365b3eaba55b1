//! Generated protobuf and gRPC code for `cleave.v1`.
#![allow(clippy::all, missing_docs)]

tonic::include_proto!("cleave.v1");

/// The encoded file descriptor set, for server reflection.
pub const FILE_DESCRIPTOR_SET: &[u8] = tonic::include_file_descriptor_set!("cleave_descriptor");
