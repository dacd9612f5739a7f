"""Writing bags as rosbag2 writes them: MCAP files, metadata.yaml, the recorder, reindexing."""
