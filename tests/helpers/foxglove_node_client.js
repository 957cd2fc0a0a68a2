// An independent Foxglove client as JavaScript apps build one, run under node by the tests: the npm
// @foxglove/ws-protocol client (0.8) with its default subprotocol, on the `ws` package, decoding
// with @foxglove/rosmsg2-serialization and jpeg-js. It subscribes to the odometry and a camera,
// publishes Twists on /quad_cmd_twist in CDR, and prints one JSON report on stdout.
//
//   NODE_PATH=<cache>/node_modules node foxglove_node_client.js ws://127.0.0.1:8765 LISTEN_S PUBLISH_S LX,LY,LZ,AZ
//
// LISTEN_S and PUBLISH_S are simulated time: the odometry's timestamps from the first one on (a
// client timed by the wall clock flies less when the simulation falls behind on a busy machine).
// It gives up after WALL_LIMIT_S on the wall clock all the same.

"use strict";
const { FoxgloveClient } = require("@foxglove/ws-protocol");
const { WebSocket } = require("ws");
const { parse } = require("@foxglove/rosmsg");
const { MessageReader, MessageWriter } = require("@foxglove/rosmsg2-serialization");
const jpeg = require("jpeg-js");

const [url, listenS, publishS, twistText] = process.argv.slice(2);
const [lx, ly, lz, az] = twistText.split(",").map(Number);
const ODOM = "/quad/odom";
const IMAGE = "/quad/front_camera/image_raw/compressed";
const TWIST_SCHEMA = "geometry_msgs/Vector3 linear\ngeometry_msgs/Vector3 angular\n" +
  "================================================================================\n" +
  "MSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z\n";

const report = { odom: [], images: 0, image: null, status: [], published: 0, undecodable: 0 };
// the default subprotocol: the one the package names (foxglove.websocket.v1 in 0.8)
const ws = new WebSocket(url, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]);
const client = new FoxgloveClient({ ws });
const readers = new Map(); // subscription id -> [topic, MessageReader]
let startNs = null; // the first odometry's timestamp (ns), and the latest one's: the client's clock
let nowNs = 0;
let lastImage = null; // the latest camera frame

client.on("open", () => {
  report.subprotocol = ws.protocol;
});
client.on("error", (err) => {
  report.error = String(err && err.message ? err.message : err);
});
client.on("serverInfo", (info) => {
  report.serverInfo = { name: info.name, capabilities: info.capabilities, supportedEncodings: info.supportedEncodings };
});
client.on("status", (status) => report.status.push(status.message));
client.on("advertise", (channels) => {
  for (const ch of channels) {
    if (ch.topic !== ODOM && ch.topic !== IMAGE) continue;
    const reader = new MessageReader(parse(ch.schema, { ros2: true }));
    readers.set(client.subscribe(ch.id), [ch.topic, reader]);
  }
});
client.on("message", ({ subscriptionId, timestamp, data }) => {
  const [topic, reader] = readers.get(subscriptionId);
  let msg;
  try {
    msg = reader.readMessage(new Uint8Array(data.buffer, data.byteOffset, data.byteLength));
  } catch (err) {
    report.undecodable += 1;
    return;
  }
  if (topic === ODOM) {
    const p = msg.pose.pose.position;
    report.odom.push([Number(timestamp), p.x, p.y, p.z]);
    if (startNs === null) startNs = Number(timestamp);
    nowNs = Math.max(nowNs, Number(timestamp));
  } else {
    report.images += 1;
    lastImage = msg; // decoded once, at the end: decoding every frame starves the 20 Hz timer
  }
});
client.on("close", () => {
  report.closed = true;
});

const WALL_LIMIT_S = 50;
const wallStart = Date.now();
const writer = new MessageWriter(parse(TWIST_SCHEMA, { ros2: true }));
let channelId = null;
const timer = setInterval(() => {
  const elapsedS = startNs === null ? 0 : (nowNs - startNs) / 1e9; // simulated seconds
  if ((startNs !== null && elapsedS >= Number(listenS)) || Date.now() - wallStart > WALL_LIMIT_S * 1000) {
    clearInterval(timer);
    ws.close();
    if (lastImage !== null) {
      const image = jpeg.decode(lastImage.data, { useTArray: true });
      let sum = 0;
      for (let i = 0; i < image.data.length; i += 4) sum += image.data[i] + image.data[i + 1] + image.data[i + 2];
      const mean = sum / (image.width * image.height * 3);
      report.image = { format: lastImage.format, width: image.width, height: image.height, mean };
    }
    process.stdout.write(JSON.stringify(report) + "\n");
    return;
  }
  if (report.serverInfo && startNs !== null && elapsedS < Number(publishS) && ws.readyState === WebSocket.OPEN) {
    if (channelId === null) {
      channelId = client.advertise({ topic: "/quad_cmd_twist", encoding: "cdr", schemaName: "geometry_msgs/msg/Twist" });
    }
    client.sendMessage(channelId, writer.writeMessage({ linear: { x: lx, y: ly, z: lz }, angular: { x: 0, y: 0, z: az } }));
    report.published += 1;
  }
}, 50); // 20 Hz, as the Teleop panel publishes
