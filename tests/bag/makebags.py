"""Small recordings made by hand for the error paths (in tmp_path, never in the repository)."""

from __future__ import annotations

import sqlite3
from pathlib import Path

QOS = ''


def make_db3(
    path: Path,
    topics: list[tuple[str, str]],
    messages: list[tuple[int, int, bytes]],
    definitions: dict[str, str] | None = None,
) -> Path:
    """A bare rosbag2 ``.db3``: ``topics`` are (name, type); ``messages`` are (topic index,
    timestamp, CDR bytes); ``definitions`` (type -> .msg text) fill the message_definitions
    table of schema 4, else the file has none (as rosbag2 before Iron wrote it)."""
    db = sqlite3.connect(path)
    try:
        db.executescript(
            """
            CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT NOT NULL, type TEXT NOT NULL,
              serialization_format TEXT NOT NULL, offered_qos_profiles TEXT NOT NULL{hash});
            CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL,
              timestamp INTEGER NOT NULL, data BLOB NOT NULL);
            """.replace('{hash}', ', type_description_hash TEXT NOT NULL' if definitions else '')
        )
        if definitions is not None:
            db.executescript(
                """
                CREATE TABLE schema(schema_version INTEGER PRIMARY KEY, ros_distro TEXT NOT NULL);
                INSERT INTO schema VALUES (4, 'jazzy');
                CREATE TABLE message_definitions(id INTEGER PRIMARY KEY,
                  topic_type TEXT NOT NULL, encoding TEXT NOT NULL,
                  encoded_message_definition TEXT NOT NULL, type_description_hash TEXT NOT NULL);
                """
            )
            for type_name, text in definitions.items():
                db.execute(
                    'INSERT INTO message_definitions(topic_type, encoding, '
                    'encoded_message_definition, type_description_hash) VALUES (?, ?, ?, ?)',
                    (type_name, 'ros2msg', text, ''),
                )
        for index, (name, type_name) in enumerate(topics, 1):
            values: tuple[object, ...] = (index, name, type_name, 'cdr', QOS)
            if definitions is not None:
                values += ('',)
            db.execute(f'INSERT INTO topics VALUES ({", ".join("?" * len(values))})', values)
        for topic, timestamp, data in messages:
            db.execute(
                'INSERT INTO messages(topic_id, timestamp, data) VALUES (?, ?, ?)',
                (topic + 1, timestamp, data),
            )
        db.commit()
    finally:
        db.close()
    return path
