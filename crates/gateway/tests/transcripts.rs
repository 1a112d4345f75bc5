//! Transcripts, byte for byte: request lines in the forms of the CiA 309-3 examples (as
//! CANopenNode documents them: `[1] 4 read 0x1017 0 i16`) against simulated devices on the
//! in-memory bus, each request sent after the previous reply.

mod common;

use canola_gateway::Config;
use common::{Client, gateway};

/// Runs `(request, expected reply)` pairs on one connection.
fn transcript(client: &mut Client, steps: &[(&str, &str)]) {
    for (request, reply) in steps {
        let n = reply.matches("\r\n").count();
        assert_eq!(client.ask(request, n), *reply, "request {request:?}");
    }
}

#[test]
fn sdo_transcript() {
    let (gw, _bus) = gateway(&[4, 5], Config::default());
    let mut c = Client::connect(&gw);
    transcript(
        &mut c,
        &[
            ("[1] 4 read 0x1017 0 i16\r\n", "[1] 500\r\n"),
            ("[2] 4 write 0x1017 0 i16 1000\r\n", "[2] OK\r\n"),
            ("[3] 4 read 0x1017 0 i16\r\n", "[3] 1000\r\n"),
            // Without a type: the node's dictionary says UNSIGNED16.
            ("[4] 4 r 0x1017 0\r\n", "[4] 1000\r\n"),
            (
                "[5] 4 r 0x1008 0 vs\r\n",
                "[5] \"Buerkert generic device\"\r\n",
            ),
            ("[6] 4 r 0x1018 1 x32\r\n", "[6] 0x00000039\r\n"),
            ("[7] 4 r 0x1018 1 u32\n", "[7] 57\r\n"),
            ("[8] 1 4 r 0x1017 0 u16\n", "[8] 1000\r\n"),
            // The object does not exist: the server's abort code.
            ("[9] 4 r 0x1234 0 u8\r\n", "[9] ERROR:0x06020000\r\n"),
            // Wrong length for the type.
            ("[10] 4 w 0x1017 0 u32 5\r\n", "[10] ERROR:0x06070012\r\n"),
            // Nobody at node 9: the client's timeout abort.
            ("[11] 9 r 0x1000 0 u32\r\n", "[11] ERROR:0x05040000\r\n"),
            (
                "[12] 4 r 0x1008 0 os\r\n",
                "[12] QnVlcmtlcnQgZ2VuZXJpYyBkZXZpY2U=\r\n",
            ),
            (
                "[13] 4 r 0x1008 0 hex\r\n",
                "[13] 42 75 65 72 6B 65 72 74 20 67 65 6E 65 72 69 63 20 64 65 76 69 63 65\r\n",
            ),
        ],
    );
}

#[test]
fn defaults_nmt_and_errors() {
    let (gw, _bus) = gateway(&[4], Config::default());
    let mut c = Client::connect(&gw);
    transcript(
        &mut c,
        &[
            ("[1] r 0x1017 0 u16\r\n", "[1] ERROR:105\r\n"),
            ("[2] set node 4\r\n", "[2] OK\r\n"),
            ("[3] r 0x1017 0 u16\r\n", "[3] 500\r\n"),
            ("[4] set sdo_timeout 100\r\n", "[4] OK\r\n"),
            ("[5] set sdo_block 1\r\n", "[5] OK\r\n"),
            (
                "[6] r 0x1008 0 vs\r\n",
                "[6] \"Buerkert generic device\"\r\n",
            ),
            ("[7] set sdo_block 0\r\n", "[7] OK\r\n"),
            ("[8] start\r\n", "[8] OK\r\n"),
            ("[9] 4 preop\r\n", "[9] OK\r\n"),
            ("[10] 0 reset comm\r\n", "[10] OK\r\n"),
            ("[11] 200 start\r\n", "[11] ERROR:107\r\n"),
            ("[12] 0 r 0x1000 0 u32\r\n", "[12] ERROR:107\r\n"),
            ("[13] 2 4 r 0x1000 0 u32\r\n", "[13] ERROR:106\r\n"),
            ("[14] set network 2\r\n", "[14] ERROR:106\r\n"),
            ("[15] set network 1\r\n", "[15] OK\r\n"),
            ("[16] frobnicate\r\n", "[16] ERROR:100\r\n"),
            ("[17] 4 read\r\n", "[17] ERROR:101\r\n"),
            // A number out of the type's range is a range error (CiA 301's abort code for a
            // value above or below the range, as the device would answer it), not a syntax
            // error; a number that is not one still is.
            (
                "[18] 4 w 0x1017 0 u16 70000\r\n",
                "[18] ERROR:0x06090031\r\n",
            ),
            ("[18] 4 w 0x1017 0 u16 -1\r\n", "[18] ERROR:0x06090032\r\n"),
            ("[18] 4 w 0x1017 0 i8 -129\r\n", "[18] ERROR:0x06090032\r\n"),
            (
                "[18] 4 w 0x1017 0 u64 99999999999999999999\r\n",
                "[18] ERROR:0x06090031\r\n",
            ),
            ("[18] 4 w 0x1017 0 u16 7x\r\n", "[18] ERROR:101\r\n"),
            ("[18] 4 r 0x1017 0 u16\r\n", "[18] 500\r\n"),
            (
                "# a comment line gets no reply\r\n[19] 4 r 0x1017 0 u16 # trailing comment\r\n",
                "[19] 500\r\n",
            ),
            // Lely's field order; class 3: the gateway is the NMT master.
            ("\r\n[20] info version\r\n", "[20] 0 0 0.1 0 3 2.0 0.1\r\n"),
            ("garbage without a sequence number\n", "ERROR:100\r\n"),
            ("[21\n", "ERROR:101\r\n"),
        ],
    );
}

#[test]
fn help_ends_with_ok() {
    let (gw, _bus) = gateway(&[], Config::default());
    let mut c = Client::connect(&gw);
    c.send("[1] help\n");
    let mut lines = Vec::new();
    loop {
        let l = c.line();
        let done = l == "[1] OK\r\n";
        lines.push(l);
        if done {
            break;
        }
    }
    assert!(lines.len() > 3, "{lines:?}");
    // Inner lines end in LF alone, the reply in CR LF (as CANopenNode writes its help).
    assert!(
        lines[..lines.len() - 1]
            .iter()
            .all(|l| l.starts_with('#') && l.ends_with('\n') && !l.ends_with("\r\n"))
    );
    assert_eq!(
        c.ask("[2] help datatype\n", 6).lines().last(),
        Some("[2] OK")
    );
}

#[test]
fn boot_up_and_heartbeat_events_for_clients_that_ask() {
    let (gw, _bus) = gateway(&[4], Config::default());
    let mut listening = Client::connect(&gw);
    let mut quiet = Client::connect(&gw);
    assert_eq!(listening.ask("[1] _events 1\n", 1), "[1] OK\r\n");
    assert_eq!(quiet.ask("[1] 4 reset node\n", 1), "[1] OK\r\n");
    // The device resets and sends its boot-up message.
    assert_eq!(listening.line(), "1 4 BOOT_UP\r\n");
    // The quiet connection got no event line: its next line is the reply.
    assert_eq!(quiet.ask("[2] 4 r 0x1017 0 u16\n", 1), "[2] 500\r\n");
    // Heartbeat monitoring: stopping the producer loses the heartbeat.
    gw.network().monitor_heartbeat(
        canola::frame::NodeId::new(4).unwrap(),
        canola::frame::Duration::from_millis(800),
    );
    // The consumer arms at the first heartbeat it sees (every 500 ms of bus time; the
    // gateway's driver keeps bus time close to real time).
    std::thread::sleep(std::time::Duration::from_millis(1500));
    assert_eq!(quiet.ask("[3] 4 w 0x1017 0 u16 0\n", 1), "[3] OK\r\n");
    let mut seen = Vec::new();
    loop {
        let l = listening.line();
        seen.push(l.clone());
        if l == "1 4 ERROR 203 (Heartbeat lost)\r\n" {
            break;
        }
        assert!(seen.len() < 10, "{seen:?}");
    }
}

#[test]
fn emcy_event_line() {
    use canola::frame::NodeId;
    use canola::nmt::{Emcy, EmcyCode, ErrorRegister};
    use canola::{MemoryBus, Network, SimDevice};

    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    let id = NodeId::new(6).unwrap();
    let dev = bus.attach(SimDevice::from_eds(id, common::EDS).unwrap());
    let gw = canola_gateway::Gateway::new(net, Config::default());
    let mut c = Client::connect(&gw);
    assert_eq!(c.ask("[1] _events 1\n", 1), "[1] OK\r\n");
    let now = bus.now();
    bus.with_station(dev, |d| {
        let mut e = Emcy::new(EmcyCode(0x8130), ErrorRegister(0x11));
        e.manufacturer = [1, 2, 3, 4, 250];
        d.signal_emcy(now, e);
    });
    // Skip the boot-up line of the attach, if the driver delivered it after `_events 1`.
    let mut l = c.line();
    if l == "1 6 BOOT_UP\r\n" {
        l = c.line();
    }
    assert_eq!(l, "1 6 EMCY 8130 11 1 2 3 4 250\r\n");
    // Events off: the next line is a reply.
    assert_eq!(c.ask("[2] _events 0\n", 1), "[2] OK\r\n");
    assert_eq!(c.ask("[3] 6 r 0x1017 0 u16\n", 1), "[3] 500\r\n");
}
