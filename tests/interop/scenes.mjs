#!/usr/bin/env node
// Foxglove's own check of `plotgate view`'s scene messages: every protobuf message of an
// MCAP file is decoded with the schema the file carries (protobufjs, from the
// FileDescriptorSet the channel's schema holds), its google.protobuf.Timestamp and Duration
// fields turned into the {sec, nsec} Foxglove's JSON schemas use (as Foxglove's own
// protobuf reader does), then validated by ajv against the JSON schema @foxglove/schemas
// publishes for its type (foxglove.SceneUpdate -> SceneUpdate, ...).
//
// Usage: node scenes.mjs FILE.mcap
// Prints one JSON line {messages, byTopic, bySchema, invalid: [first 20]} and exits 0 when
// every protobuf message validates and there is at least one, 1 otherwise, 2 on bad usage.

import { open } from "node:fs/promises";
import { createRequire } from "node:module";

import * as zstd from "@foxglove/wasm-zstd";
import { McapIndexedReader } from "@mcap/core";
import { FileHandleReadable } from "@mcap/nodejs";
import Ajv from "ajv";
import protobuf from "protobufjs";
import descriptor from "protobufjs/ext/descriptor/index.js";

const require = createRequire(import.meta.url);
const jsonSchemas = require("@foxglove/schemas/jsonschema");

const TIME_TYPES = new Set([".google.protobuf.Timestamp", ".google.protobuf.Duration"]);

// protobufjs's object of a message, with every time as {sec, nsec}.
function foxgloveTimes(type, value) {
  if (value === null || typeof value !== "object") return value;
  for (const field of type.fieldsArray) {
    const v = value[field.name];
    if (v === null || v === undefined || !field.resolvedType || !field.resolvedType.fields) continue;
    const convert = (item) =>
      TIME_TYPES.has(field.resolvedType.fullName)
        ? { sec: Number(item.seconds), nsec: Number(item.nanos) }
        : foxgloveTimes(field.resolvedType, item);
    value[field.name] = field.repeated ? v.map(convert) : convert(v);
  }
  return value;
}

async function main() {
  const [path] = process.argv.slice(2);
  if (!path) {
    console.error("usage: node scenes.mjs FILE.mcap");
    process.exit(2);
  }
  await zstd.isLoaded;
  const handle = await open(path, "r");
  const reader = await McapIndexedReader.Initialize({
    readable: new FileHandleReadable(handle),
    decompressHandlers: { zstd: (buffer, size) => zstd.decompress(buffer, Number(size)) },
  });
  const ajv = new Ajv({ allErrors: true, strict: false });
  const types = new Map();
  const report = { messages: 0, byTopic: {}, bySchema: {}, invalid: [] };
  for await (const message of reader.readMessages()) {
    const channel = reader.channelsById.get(message.channelId);
    if (channel.messageEncoding !== "protobuf") continue;
    const schema = reader.schemasById.get(channel.schemaId);
    if (!types.has(schema.id)) {
      const set = descriptor.FileDescriptorSet.decode(schema.data);
      const root = protobuf.Root.fromDescriptor(set);
      const short = schema.name.replace(/^foxglove\./, "");
      types.set(schema.id, {
        type: root.lookupType(schema.name),
        validate: ajv.compile(jsonSchemas[short]),
      });
    }
    const { type, validate } = types.get(schema.id);
    const decoded = type.toObject(type.decode(message.data), {
      defaults: true,
      arrays: true,
      longs: Number,
      enums: Number,
      bytes: String,
    });
    const value = foxgloveTimes(type, decoded);
    report.messages += 1;
    report.byTopic[channel.topic] = (report.byTopic[channel.topic] ?? 0) + 1;
    report.bySchema[schema.name] = (report.bySchema[schema.name] ?? 0) + 1;
    if (!validate(value) && report.invalid.length < 20) {
      report.invalid.push({ topic: channel.topic, errors: validate.errors.slice(0, 5) });
    }
  }
  await handle.close();
  console.log(JSON.stringify(report));
  process.exit(report.messages > 0 && report.invalid.length === 0 ? 0 : 1);
}

main().catch((err) => {
  console.error(err);
  process.exit(1);
});
