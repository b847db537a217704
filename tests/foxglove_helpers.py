"""Decoding Foxglove's protobuf messages in tests, from the schema a file or a server carries."""

from __future__ import annotations

from typing import Any

from google.protobuf import descriptor_pb2, descriptor_pool, message_factory


def message_class(schema_name: str, file_descriptor_set: bytes) -> Any:
    """The protobuf message class of ``schema_name``, built from its FileDescriptorSet (as advertised or stored)."""
    files = descriptor_pb2.FileDescriptorSet.FromString(file_descriptor_set)
    pool = descriptor_pool.DescriptorPool()
    for proto in files.file:
        pool.Add(proto)
    return message_factory.GetMessageClass(pool.FindMessageTypeByName(schema_name))
