// A ROS 2 node that is not built on Cyclone DDS: @foxglove/ros2 and @foxglove/rtps (RTPS in
// TypeScript), with ROS 2 Humble's message definitions from @foxglove/rosmsg-msgs-common and
// their CDR from @foxglove/rosmsg2-serialization. test_foxglove_peer.cpp runs it against
// projtour's ros2 drivers, so what they send and read is checked by another implementation of
// the wire than the one they are built on.
//
// It subscribes to cmd_vel (geometry_msgs/msg/Twist) and prints every Twist it takes, publishes
// odom (nav_msgs/msg/Odometry) and scan (sensor_msgs/msg/LaserScan) at --rate-hz with values
// that are functions of the message's index k (below, and in the test), and ends after
// --duration-s or on SIGTERM. SIGUSR1 stops odom (the base's computer hangs) and keeps the rest.
// Everything it says is one JSON object a line on stdout; diagnostics go to stderr.
//
// Two options show @foxglove/ros2 as it is, failing against projtour's drivers (run the test with
// PROJTOUR_ROS2_PEER_ARGS="--no-qos-defaults" or "--subscribe-via rosnode"): below, at each.
//
// Nothing leaves the machine. @foxglove/rtps binds 0.0.0.0, joins 239.255.0.1 and sends its
// participant announcement (SPDP) there; the sockets handed to it here bind 127.0.0.1 only,
// never join a group (a join sends IGMP on the default interface), and send only to
// 127.0.0.0/8: the announcement goes by unicast to the participant ports of 127.0.0.1 (indices
// 0..30, as projtour's loopback configuration of Cyclone has them). Any other destination is
// dropped and counted, and the count is in the last line ("refused_sends"), for the test.
import dgram from "node:dgram";
import { createRequire } from "node:module";

const require = createRequire(import.meta.url);
const { RosNode, Subscription } = require("@foxglove/ros2");
const rtps = require("@foxglove/rtps");
const { MessageReader, MessageWriter } = require("@foxglove/rosmsg2-serialization");
const { ros2humble } = require("@foxglove/rosmsg-msgs-common");

// ---- command line ----
const args = {
  domain: undefined,
  durationS: 20,
  rateHz: 20,
  subscribeVia: "participant",
  qosDefaults: true,
};
for (let i = 2; i < process.argv.length; i++) {
  const a = process.argv[i];
  const next = () => {
    if (i + 1 >= process.argv.length) fail(`${a} needs a value`);
    return process.argv[++i];
  };
  if (a === "--domain") args.domain = Number(next());
  else if (a === "--duration-s") args.durationS = Number(next());
  else if (a === "--rate-hz") args.rateHz = Number(next());
  // "rosnode": RosNode.subscribe as the library offers it (transient-local reader QoS);
  // "participant": the same subscription through its Participant with a volatile reader.
  else if (a === "--subscribe-via") args.subscribeVia = next();
  // @foxglove/rtps as published: no RTPS default for a reliability left out of discovery.
  else if (a === "--no-qos-defaults") args.qosDefaults = false;
  else fail(`unknown argument ${a}`);
}
if (!Number.isInteger(args.domain) || args.domain < 0 || args.domain > 232) {
  fail("--domain must be an integer in 0..232");
}

function fail(why) {
  process.stderr.write(`peer.mjs: ${why}\n`);
  process.exit(2);
}

// RTPS time of the wall clock, for the writers' INFO_TS.
function now() {
  const ms = Date.now();
  return { sec: Math.floor(ms / 1000), nsec: (ms % 1000) * 1e6 };
}

function say(obj) {
  process.stdout.write(JSON.stringify(obj) + "\n");
}

// ---- sockets kept on loopback ----
const LOOPBACK = "127.0.0.1";
const MAX_PARTICIPANT_INDEX = 30;
let refusedSends = 0;
const spdpMulticastPort = rtps.discoveryMulticastPort(args.domain);

function isLoopback(address) {
  return /^127\.\d+\.\d+\.\d+$/.test(address);
}

class LoopbackUdpSocket {
  constructor() {
    this._socket = dgram.createSocket({ type: "udp4", reuseAddr: true });
  }
  on(event, listener) {
    this._socket.on(event, listener);
    return this;
  }
  async remoteAddress() {
    return undefined;
  }
  async localAddress() {
    return this._socket.address();
  }
  async bind(_options) {
    // The participant asks for the SPDP multicast port on 0.0.0.0 for its "multicast" socket and
    // an ephemeral port on 0.0.0.0 for its unicast one: both become ephemeral ports of
    // 127.0.0.1 (nothing is sent to the multicast port here, so nothing needs to listen on it).
    await new Promise((resolve, reject) => {
      this._socket.once("error", reject);
      this._socket.bind({ address: LOOPBACK, port: 0 }, () => {
        this._socket.removeListener("error", reject);
        resolve();
      });
    });
  }
  async addMembership(group) {
    process.stderr.write(`peer.mjs: not joining multicast group ${group} (loopback only)\n`);
  }
  async dropMembership() {}
  async setBroadcast() {}
  async setMulticastInterface() {}
  async setMulticastLoopback() {}
  async setMulticastTTL() {}
  async connect() {
    throw new Error("connect is not used by @foxglove/rtps");
  }
  async close() {
    await new Promise((resolve) => this._socket.close(() => resolve()));
  }
  async dispose() {
    await this.close();
  }
  async send(data, offset, length, port, address) {
    let targets;
    if (isLoopback(address)) {
      targets = [port];
    } else if (address === rtps.MULTICAST_IPv4 && port === spdpMulticastPort) {
      targets = [];
      for (let i = 0; i <= MAX_PARTICIPANT_INDEX; i++) {
        targets.push(rtps.discoveryUnicastPort(args.domain, i));
      }
    } else {
      refusedSends++;
      process.stderr.write(`peer.mjs: refused to send to ${address}:${port}\n`);
      return;
    }
    const bytes = Buffer.from(data.buffer, data.byteOffset + offset, length);
    await Promise.all(
      targets.map(
        (p) =>
          new Promise((resolve) => {
            // A participant port nobody holds answers with ICMP unreachable (an error here):
            // discovery goes on with the ports that are held.
            this._socket.send(bytes, p, LOOPBACK, () => resolve());
          }),
      ),
    );
  }
}

// ---- messages ----
// ROS 2 Humble's definition of `type` with every type it uses, the form MessageWriter reads.
function definitionsOf(type) {
  const out = [];
  const seen = new Set();
  const visit = (name) => {
    if (seen.has(name)) return;
    seen.add(name);
    const def = ros2humble[name];
    if (def == undefined) fail(`no ROS 2 Humble definition of ${name}`);
    out.push(def);
    for (const f of def.definitions) if (f.isComplex === true) visit(f.type);
  };
  visit(type);
  return out;
}

const TWIST = "geometry_msgs/Twist";
const ODOMETRY = "nav_msgs/Odometry";
const LASER_SCAN = "sensor_msgs/LaserScan";
const twistReader = new MessageReader(definitionsOf(TWIST));
const odometryWriter = new MessageWriter(definitionsOf(ODOMETRY));
const scanWriter = new MessageWriter(definitionsOf(LASER_SCAN));

// Message k of odom and scan; test_foxglove_peer.cpp computes the same. The values are exact in
// binary (float32 for the scan), so the test compares them for equality.
const YAW_RAD = 0.625;
function odometryMessage(k) {
  const covariance = Array.from({ length: 36 }, (_, i) => (i % 7 === 0 ? 0.01 * (1 + i) : 0));
  return {
    header: { stamp: { sec: 1000 + k, nanosec: 987654321 - k }, frame_id: "odom" },
    child_frame_id: "base_link",
    pose: {
      pose: {
        position: { x: 1.5 + 0.25 * k, y: -2.75, z: 0 },
        orientation: { x: 0, y: 0, z: Math.sin(YAW_RAD / 2), w: Math.cos(YAW_RAD / 2) },
      },
      covariance,
    },
    twist: {
      twist: { linear: { x: 0.375, y: 0, z: 0 }, angular: { x: 0, y: 0, z: -0.125 } },
      covariance,
    },
  };
}

const SCAN_READINGS = 13;
function scanMessage(k) {
  const ranges = Array.from({ length: SCAN_READINGS }, (_, i) => 0.5 + 0.25 * i + 0.125 * (k % 4));
  ranges[3] = Infinity; // no return (REP 117)
  ranges[7] = NaN; // a broken reading
  ranges[10] = 0.0625; // below range_min
  return {
    header: { stamp: { sec: 2000 + k, nanosec: 250000000 + k }, frame_id: "laser" },
    angle_min: -1.5,
    angle_max: 1.5,
    angle_increment: 0.25,
    time_increment: 0,
    scan_time: 0.05,
    range_min: 0.125,
    range_max: 25,
    ranges: Float32Array.from(ranges),
    intensities: new Float32Array(0),
  };
}

// ---- publishing on @foxglove/rtps ----
// @foxglove/ros2 1.0.8 subscribes only (RosNode's advertise and publish are commented out), and
// @foxglove/rtps 1.6.0 has writers but announces only subscriptions. A publication is made here
// from its parts: a Writer in the participant's writers, its DCPSPublication announcement
// written to the built-in publications writer, the remote readers of its topic matched as they
// are announced (the participant records them but leaves the match to a writer, "FIXME"), and
// each sample written to the writer's history and sent with sendDefaultChanges.
const { ChangeKind, Durability, EntityIdBuiltin, EntityKind, HistoryKind, Reliability } = rtps;
let nextWriterKey = 0x100; // clear of the keys the participant gives its subscriptions
class Publication {
  constructor(participant, topicName, typeName) {
    this.participant = participant;
    this.topicName = topicName;
    this.typeName = typeName;
    this.entityId = rtps.makeEntityId(nextWriterKey++, EntityKind.AppdefWriterNoKey);
    this.guid = rtps.makeGuid(participant.attributes.guidPrefix, this.entityId);
    this.matched = new Set();
    this.writer = new rtps.Writer({
      guidPrefix: participant.attributes.guidPrefix,
      entityId: this.entityId,
      topicName,
      typeName,
      durability: Durability.Volatile,
      reliability: { kind: Reliability.Reliable, maxBlockingTime: { sec: 0, nsec: 100000000 } },
      history: { kind: HistoryKind.KeepLast, depth: 1 },
      protocolVersion: participant.attributes.protocolVersion,
      vendorId: participant.attributes.vendorId,
    });
    participant._writers.set(this.entityId, this.writer);
    participant.on("discoveredSubscription", (reader) => this.match(reader));
    this.announce();
  }

  announce() {
    const p = this.participant;
    const builtin = p._writers.get(EntityIdBuiltin.PublicationsWriter);
    const params = new rtps.Parameters();
    params.topicName(this.topicName);
    params.typeName(this.typeName);
    params.durability(this.writer.attributes.durability);
    params.reliability(this.writer.attributes.reliability);
    params.history(this.writer.attributes.history);
    params.protocolVersion(p.attributes.protocolVersion);
    params.vendorId(p.attributes.vendorId);
    params.endpointGuid(this.guid);
    params.finish();
    builtin.history.set({
      timestamp: now(),
      kind: ChangeKind.Alive,
      writerGuid: rtps.makeGuid(p.attributes.guidPrefix, EntityIdBuiltin.PublicationsWriter),
      sequenceNumber: builtin.history.nextSequenceNum(),
      data: params.data,
      instanceHandle: this.guid,
    });
    void p.sendMetatrafficChanges(builtin);
  }

  match(reader) {
    if (reader.topicName !== this.topicName || reader.typeName !== this.typeName) return;
    const view = this.participant._participants.get(reader.guidPrefix);
    if (view == undefined) return;
    const key = rtps.makeGuid(reader.guidPrefix, reader.entityId);
    if (this.matched.has(key)) return;
    this.matched.add(key);
    rtps.addToMultiMap(this.entityId, reader.entityId, view.localWriterIdToRemoteReaderIds);
    say({ event: "reader_matched", topic: this.topicName, reader: key });
  }

  async write(data) {
    this.writer.history.set({
      timestamp: now(),
      kind: ChangeKind.Alive,
      writerGuid: this.guid,
      sequenceNumber: this.writer.history.nextSequenceNum(),
      data,
      instanceHandle: this.guid,
    });
    await this.participant.sendDefaultChanges(this.writer);
  }
}

// ---- the node ----
const node = new RosNode({
  name: "foxglove_peer",
  domainId: args.domain,
  addresses: [LOOPBACK],
  udpSocketCreate: async () => new LoopbackUdpSocket(),
  log: {
    warn: (m) => process.stderr.write(`rtps warn: ${m}\n`),
    error: (m) => process.stderr.write(`rtps error: ${m}\n`),
  },
});
const participant = node._participant;
// @foxglove/rtps says it is Eclipse Cyclone DDS (vendor 0x0110) unless told otherwise, which
// RosNode never does; Cyclone reads a vendor's own parameters only from that vendor. This peer
// says "unknown vendor" (0x0000), so Cyclone treats it as the foreign implementation it is.
participant.attributes.vendorId = rtps.VendorId.Unknown;

// RTPS 2.x (9.6.2.2, tables 9.13 and 9.14): a reliability left out of an endpoint's discovery
// data means RELIABLE for a writer (DiscoveredWriterData) and BEST_EFFORT for a reader. Cyclone
// leaves out every QoS at its default, so its reliable writers announce none; @foxglove/rtps
// 1.6.0 requires the parameter (parseEndpoint) and drops such an endpoint ("failed to parse
// publication attributes"), and then never hears what it writes. The spec's default is filled
// in here while the participant parses an endpoint, and each one so filled is said on stdout.
if (args.qosDefaults) {
  const readReliability = rtps.ParametersView.prototype.reliability;
  let fallback;
  rtps.ParametersView.prototype.reliability = function reliability() {
    return readReliability.call(this) ?? fallback;
  };
  const withDefault = (kind, what, parse) => (data, timestamp) => {
    const params = rtps.ParametersView.FromCdr(data);
    if (params != undefined && readReliability.call(params) == undefined) {
      say({ event: "qos_default", endpoint: what, topic: params.topicName(), reliability: kind });
    }
    fallback = { kind: Reliability[kind], maxBlockingTime: { sec: 0, nsec: 100000000 } };
    try {
      return parse(data, timestamp);
    } finally {
      fallback = undefined;
    }
  };
  const { handlePublication, handleSubscription } = participant;
  participant.handlePublication = withDefault("Reliable", "publication", handlePublication);
  participant.handleSubscription = withDefault("BestEffort", "subscription", handleSubscription);
}
participant.on("error", (err) => process.stderr.write(`rtps error: ${err}\n`));
node.on("discoveredParticipant", (p) =>
  say({ event: "participant", guid_prefix: p.guidPrefix, vendor: p.vendorId }),
);
node.on("discoveredPublication", (e) =>
  say({ event: "publication", topic: e.topicName, type: e.typeName }),
);

await node.start();

let cmdVelCount = 0;
function onTwist(_timestamp, _msg, data) {
  const t = twistReader.readMessage(data);
  cmdVelCount++;
  say({ event: "cmd_vel", n: cmdVelCount, linear: t.linear, angular: t.angular });
}
if (args.subscribeVia === "rosnode") {
  node.subscribe({ topic: "/cmd_vel", dataType: "geometry_msgs/msg/Twist" }).on("message", onTwist);
} else if (args.subscribeVia === "participant") {
  // RosNode.subscribe asks for a transient-local reader, which a volatile writer (ROS 2's
  // default, and projtour's cmd_vel) does not serve: DDS matches a reader only with a writer
  // whose durability is at least the reader's. The same subscription, volatile.
  const opts = {
    topicName: "rt/cmd_vel",
    typeName: "geometry_msgs::msg::dds_::Twist_",
    durability: Durability.Volatile,
    reliability: { kind: Reliability.Reliable, maxBlockingTime: { sec: 0, nsec: 100000000 } },
    history: { kind: HistoryKind.KeepLast, depth: 100 },
  };
  const readerEntityId = participant.subscribe(opts);
  new Subscription({ subscribeOpts: opts, readerEntityId, participant }).on("message", onTwist);
} else {
  fail(`--subscribe-via is rosnode or participant, not ${args.subscribeVia}`);
}

const odom = new Publication(participant, "rt/odom", "nav_msgs::msg::dds_::Odometry_");
const scan = new Publication(participant, "rt/scan", "sensor_msgs::msg::dds_::LaserScan_");

// @foxglove/rtps announces its participant once, at start: announce it again every 0.5 s, as
// Cyclone does, so a participant that comes later finds this one.
const announcer = setInterval(
  () => void participant.broadcastParticipant(participant.attributes),
  500,
);

let k = 0;
let odomOn = true;
let odomSent = 0;
let scanSent = 0;
const publisher = setInterval(async () => {
  if (odomOn) {
    await odom.write(odometryWriter.writeMessage(odometryMessage(k)));
    odomSent++;
  }
  await scan.write(scanWriter.writeMessage(scanMessage(k)));
  scanSent++;
  k++;
}, 1000 / args.rateHz);

process.on("SIGUSR1", () => {
  odomOn = false;
  say({ event: "odom_stopped", k });
});

let ending = false;
async function end(reason) {
  if (ending) return;
  ending = true;
  clearInterval(publisher);
  clearInterval(announcer);
  say({
    event: "end",
    reason,
    cmd_vel_count: cmdVelCount,
    odom_sent: odomSent,
    scan_sent: scanSent,
    refused_sends: refusedSends,
  });
  await node.shutdown();
  // Let the shutdown's last datagrams go before the sockets close.
  setTimeout(() => process.exit(0), 100);
}
process.on("SIGTERM", () => void end("SIGTERM"));
setTimeout(() => void end("duration"), args.durationS * 1000);
say({ event: "ready", domain: args.domain, guid_prefix: participant.attributes.guidPrefix });
