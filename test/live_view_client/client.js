// Test-only: connect to the live view with the official Foxglove WebSocket protocol client, subscribe to every
// advertised channel, decode each message by its advertised schema (ros2msg + CDR with Foxglove's ROS 2
// deserialiser, protobuf with protobufjs from the advertised FileDescriptorSet), fetch assets, and print one JSON
// summary. Nothing here is the project's own code: it is what Foxglove does with the server.
//
// usage: node client.js ws://127.0.0.1:PORT SECONDS [asset-uri ...]
"use strict";
const { FoxgloveClient } = require("@foxglove/ws-protocol");
const { parse } = require("@foxglove/rosmsg");
const { MessageReader } = require("@foxglove/rosmsg2-serialization");
const protobuf = require("protobufjs");
const descriptor = require("protobufjs/ext/descriptor");
const WebSocket = require("ws");

const [url, secondsText, ...assets] = process.argv.slice(2);
const seconds = Number(secondsText);
// The SDK's server speaks the protocol under its newer name, foxglove.sdk.v1 (the same messages as
// foxglove.websocket.v1, which this client library names); the client leaves the name to the socket.
const client = new FoxgloveClient({ ws: new WebSocket(url, ["foxglove.sdk.v1"]) });
const channels = new Map(); // channel id -> {topic, encoding, schemaName, schemaEncoding, decode}
const bySubscription = new Map();
const topics = {}; // topic -> {schemaName, encoding, schemaEncoding, received, decoded, errors, sample}
const assetResults = {};
let serverInfo = null;

function decoderFor(channel) {
  if (channel.encoding === "cdr" && channel.schemaEncoding === "ros2msg") {
    const reader = new MessageReader(parse(channel.schema, { ros2: true }));
    return (bytes) => reader.readMessage(bytes);
  }
  if (channel.encoding === "protobuf") {
    const set = descriptor.FileDescriptorSet.decode(Buffer.from(channel.schema, "base64"));
    const type = protobuf.Root.fromDescriptor(set).lookupType(channel.schemaName);
    return (bytes) => type.toObject(type.decode(bytes), { longs: Number, defaults: true });
  }
  throw new Error(`no decoder for encoding ${channel.encoding} / schema ${channel.schemaEncoding}`);
}

function plain(value) {
  return JSON.parse(JSON.stringify(value, (_, v) => {
    if (typeof v === "bigint") return Number(v);
    if (ArrayBuffer.isView(v)) return Array.from(v);
    return v;
  }));
}

client.on("serverInfo", (info) => { serverInfo = info; });
client.on("advertise", (advertised) => {
  for (const channel of advertised) {
    const entry = { topic: channel.topic, schemaName: channel.schemaName, encoding: channel.encoding,
      schemaEncoding: channel.schemaEncoding ?? null, received: 0, decoded: 0, errors: [], sample: null };
    topics[channel.topic] = entry;
    try {
      channels.set(channel.id, { entry, decode: decoderFor(channel) });
    } catch (error) {
      entry.errors.push(String(error));
      continue;
    }
    bySubscription.set(client.subscribe(channel.id), channel.id);
  }
});
client.on("message", ({ subscriptionId, data }) => {
  const channel = channels.get(bySubscription.get(subscriptionId));
  if (!channel) return;
  channel.entry.received += 1;
  try {
    const message = channel.decode(new Uint8Array(data.buffer, data.byteOffset, data.byteLength));
    channel.entry.decoded += 1;
    channel.entry.sample = plain(message);
  } catch (error) {
    if (channel.entry.errors.length < 3) channel.entry.errors.push(String(error));
  }
});
client.on("fetchAssetResponse", (response) => {
  const uri = assets[response.requestId];
  assetResults[uri] = response.status === 0
    ? { ok: true, bytes: response.data.byteLength }
    : { ok: false, error: response.error };
});
client.on("open", () => { assets.forEach((uri, index) => client.fetchAsset(uri, index)); });
client.on("error", (error) => { process.stderr.write(`client error: ${error}\n`); });

setTimeout(() => {
  for (const entry of Object.values(topics)) {
    // Keep the summary small: the big arrays of a sample are cut to their first elements.
    entry.sample = JSON.parse(JSON.stringify(entry.sample, (_, v) => (Array.isArray(v) && v.length > 16 ? v.slice(0, 16) : v)));
    if (typeof entry.sample?.data === "string" && entry.sample.data.length > 200) {
      entry.sample.data_length = entry.sample.data.length;
      entry.sample.data = entry.sample.data.slice(0, 200);
    }
  }
  process.stdout.write(JSON.stringify({ serverInfo: serverInfo && { name: serverInfo.name,
    capabilities: serverInfo.capabilities }, topics, assets: assetResults }) + "\n");
  client.close();
  process.exit(0);
}, seconds * 1000);
