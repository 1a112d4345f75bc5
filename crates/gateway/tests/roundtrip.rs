//! Property tests of the line grammar: formatting a generated request and parsing the text gives
//! the request back (and the text again), and no line of arbitrary text makes the parser panic.

use canola_gateway::command::{AllNodes, AllNodesAssign, HelpTopic, ScanType};
use canola_gateway::value::{TIME_MS_MAX, Time};
use canola_gateway::{Command, DataType, NmtService, Request, Value, parse_line};
use proptest::prelude::*;

fn bytes() -> impl Strategy<Value = Vec<u8>> {
    proptest::collection::vec(any::<u8>(), 0..40)
}

fn time() -> impl Strategy<Value = Time> {
    (any::<u16>(), 0..=TIME_MS_MAX).prop_map(|(days, ms)| Time { days, ms })
}

fn value() -> impl Strategy<Value = Value> {
    prop_oneof![
        any::<bool>().prop_map(Value::Bool),
        any::<i8>().prop_map(Value::I8),
        any::<i16>().prop_map(Value::I16),
        any::<i32>().prop_map(Value::I32),
        any::<i64>().prop_map(Value::I64),
        any::<u8>().prop_map(Value::U8),
        any::<u16>().prop_map(Value::U16),
        any::<u32>().prop_map(Value::U32),
        any::<u64>().prop_map(Value::U64),
        any::<u8>().prop_map(Value::X8),
        any::<u16>().prop_map(Value::X16),
        any::<u32>().prop_map(Value::X32),
        any::<u64>().prop_map(Value::X64),
        any::<f32>()
            .prop_filter("NaN is not equal to itself", |v| !v.is_nan())
            .prop_map(Value::R32),
        any::<f64>()
            .prop_filter("NaN is not equal to itself", |v| !v.is_nan())
            .prop_map(Value::R64),
        time().prop_map(Value::TimeOfDay),
        time().prop_map(Value::TimeDifference),
        // Visible characters, blanks, quotes and '#', no line ends.
        "[ -~\t]{0,30}".prop_map(Value::VisibleString),
        bytes().prop_map(Value::OctetString),
        bytes().prop_map(Value::UnicodeString),
        bytes().prop_map(Value::Domain),
        bytes().prop_map(Value::Hex),
    ]
}

fn data_type() -> impl Strategy<Value = DataType> {
    proptest::sample::select(DataType::ALL.to_vec())
}

fn scan_type() -> impl Strategy<Value = ScanType> {
    prop_oneof![
        Just(ScanType::Scan),
        Just(ScanType::Ignore),
        Just(ScanType::Match)
    ]
}

fn node_command() -> impl Strategy<Value = Command> {
    prop_oneof![
        (any::<u16>(), any::<u8>(), proptest::option::of(data_type())).prop_map(
            |(index, sub, data_type)| Command::Read {
                index,
                sub,
                data_type
            }
        ),
        (any::<u16>(), any::<u8>(), value()).prop_map(|(index, sub, value)| Command::Write {
            index,
            sub,
            value
        }),
        prop_oneof![
            Just(NmtService::Start),
            Just(NmtService::Stop),
            Just(NmtService::PreOperational),
            Just(NmtService::ResetNode),
            Just(NmtService::ResetCommunication),
        ]
        .prop_map(Command::Nmt),
    ]
}

fn network_command() -> impl Strategy<Value = Command> {
    let all_nodes = (
        any::<u16>(),
        proptest::option::of((
            1u8..=127,
            any::<bool>(),
            proptest::option::of(proptest::array::uniform4((scan_type(), any::<u32>()))),
        )),
    )
        .prop_map(|(timeout_ms, assign)| AllNodes {
            timeout_ms,
            assign: assign.map(|(node_start, store, scan)| AllNodesAssign {
                node_start,
                store,
                scan,
            }),
        });
    prop_oneof![
        any::<u16>().prop_map(Command::SetNetwork),
        any::<u8>().prop_map(Command::SetNode),
        any::<u32>().prop_map(Command::SetSdoTimeout),
        any::<bool>().prop_map(Command::SetSdoBlock),
        any::<bool>().prop_map(Command::LssSwitchGlobal),
        any::<[u32; 4]>().prop_map(Command::LssSwitchSelective),
        any::<u8>().prop_map(Command::LssSetNode),
        (any::<u8>(), any::<u8>())
            .prop_map(|(table, index)| Command::LssConfBitrate { table, index }),
        any::<u16>().prop_map(Command::LssActivateBitrate),
        Just(Command::LssStore),
        proptest::option::of(0u8..=3).prop_map(Command::LssInquireAddr),
        Just(Command::LssGetNode),
        proptest::option::of(any::<u16>()).prop_map(Command::LssFastscan),
        proptest::option::of(all_nodes).prop_map(Command::LssAllNodes),
    ]
}

fn gateway_command() -> impl Strategy<Value = Command> {
    prop_oneof![
        prop_oneof![
            Just(None),
            Just(Some(HelpTopic::DataType)),
            Just(Some(HelpTopic::Lss))
        ]
        .prop_map(Command::Help),
        Just(Command::InfoVersion),
        any::<bool>().prop_map(Command::Events),
    ]
}

fn request() -> impl Strategy<Value = Request> {
    let seq = proptest::option::of(any::<u32>());
    prop_oneof![
        (
            seq.clone(),
            // Node-IDs 0..=127 (0: all nodes); a larger one is refused with error 107.
            proptest::option::of((proptest::option::of(any::<u16>()), 0u8..=127)),
            node_command()
        )
            .prop_map(|(seq, target, command)| {
                let (net, node) = match target {
                    Some((net, node)) => (net, Some(node)),
                    None => (None, None),
                };
                Request {
                    seq,
                    net,
                    node,
                    command,
                }
            }),
        (
            seq.clone(),
            proptest::option::of(any::<u16>()),
            network_command()
        )
            .prop_map(|(seq, net, command)| Request {
                seq,
                net,
                node: None,
                command
            }),
        (seq, gateway_command()).prop_map(|(seq, command)| Request {
            seq,
            net: None,
            node: None,
            command
        }),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn format_then_parse_is_the_identity(req in request(), crlf in any::<bool>(), comment in any::<bool>()) {
        let mut line = req.to_string();
        if comment {
            line.push_str("  # a comment");
        }
        line.push_str(if crlf { "\r\n" } else { "\n" });
        let back = parse_line(&line).map_err(|e| TestCaseError::fail(format!("{line:?}: {e}")))?;
        prop_assert_eq!(back.as_ref(), Some(&req), "{:?}", line);
        prop_assert_eq!(back.unwrap().to_string(), req.to_string());
    }

    #[test]
    fn any_text_parses_or_fails_cleanly(line in "\\PC{0,80}") {
        let _ = parse_line(&line);
    }

    #[test]
    fn near_miss_lines_parse_or_fail_cleanly(
        req in request(),
        cut in 0usize..200,
        junk in "[ -~]{0,4}",
    ) {
        let text = req.to_string();
        let mut at = cut.min(text.len());
        while !text.is_char_boundary(at) {
            at -= 1;
        }
        let line = format!("{}{}{}", &text[..at], junk, &text[at..]);
        if let Ok(Some(r)) = parse_line(&line) {
            // Whatever parses formats to a line that parses to the same request.
            prop_assert_eq!(parse_line(&r.to_string()), Ok(Some(r.clone())));
        }
    }
}
