//! MCAP recording: channels, schemas, chunking, rotation, clean finalisation.
