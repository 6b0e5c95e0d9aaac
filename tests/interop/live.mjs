#!/usr/bin/env node
// A Foxglove WebSocket client (@foxglove/ws-protocol, the protocol library Foxglove's app is
// built on, over `ws`) for the live view's test: connects with the foxglove.websocket.v1
// subprotocol, subscribes to TOPIC when the server advertises it, and prints one JSON line
// per event: {"subscribed": topic, schemaName, encoding} then, per message received,
// {"topic", "timestamp", "data"} (data in base64). Exits 0 after COUNT messages, 1 on an
// error or when none came within TIMEOUT_S seconds.
//
// Usage: node live.mjs ws://127.0.0.1:PORT TOPIC [COUNT] [TIMEOUT_S]

import wsProtocol from "@foxglove/ws-protocol";
import { WebSocket } from "ws";

const { FoxgloveClient } = wsProtocol; // a CommonJS package
const SUBPROTOCOL = "foxglove.sdk.v1";

const [url, topic, count = "1", timeoutS = "60"] = process.argv.slice(2);
if (!url || !topic) {
  console.error("usage: node live.mjs ws://127.0.0.1:PORT TOPIC [COUNT] [TIMEOUT_S]");
  process.exit(2);
}
// foxglove-sdk's server speaks the protocol's current name, foxglove.sdk.v1, and refuses the
// handshake of its first name, which this library still sends by default
const client = new FoxgloveClient({ ws: new WebSocket(url, [SUBPROTOCOL]) });
let received = 0;
const subscriptions = new Map();
setTimeout(() => {
  console.error(`no message on ${topic} within ${timeoutS} s`);
  process.exit(1);
}, Number(timeoutS) * 1000);
client.on("error", (err) => {
  console.error(String(err));
  process.exit(1);
});
client.on("advertise", (channels) => {
  for (const channel of channels) {
    if (channel.topic !== topic) continue;
    subscriptions.set(client.subscribe(channel.id), channel);
    const { schemaName, encoding } = channel;
    console.log(JSON.stringify({ subscribed: topic, schemaName, encoding }));
  }
});
client.on("message", ({ subscriptionId, timestamp, data }) => {
  const channel = subscriptions.get(subscriptionId);
  const bytes = Buffer.from(data.buffer, data.byteOffset, data.byteLength);
  console.log(
    JSON.stringify({ topic: channel.topic, timestamp: String(timestamp), data: bytes.toString("base64") }),
  );
  received += 1;
  if (received >= Number(count)) {
    client.close();
    process.exit(0);
  }
});
