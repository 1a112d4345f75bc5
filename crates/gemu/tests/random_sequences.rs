//! Random operation sequences: the client against the simulator (and against a silent device)
//! never panics, never loses a request, and never reports two active actions.

use canola_frame::{Duration, Instant};
use canola_gemu::action::{
    ActionId, ActionRequest, ErrorCode, FindFunctionFunction, GoFunction, NoInitFunction,
    RunFunction,
};
use canola_gemu::client::{Client, ClientConfig, Event};
use canola_gemu::params::{PARAMETERS, ParamId};
use canola_gemu::sim::SimulatedCpos;
use proptest::prelude::*;
use std::collections::BTreeSet;

#[derive(Debug, Clone)]
enum Op {
    Get(usize),
    Set(usize, i32),
    SetRaw(u16, u32),
    ErrorList(u16),
    Errors(u16),
    Warnings(u16),
    Action(u8, u8),
    Quit,
    RaiseError(u8),
    LocalChange(usize, i32),
    Air(bool),
    Wait(u16),
    Disconnect(bool),
}

fn op() -> impl Strategy<Value = Op> {
    prop_oneof![
        (0..PARAMETERS.len()).prop_map(Op::Get),
        (0..PARAMETERS.len(), -1100..1100i32).prop_map(|(i, v)| Op::Set(i, v)),
        (any::<u16>(), any::<u32>()).prop_map(|(i, v)| Op::SetRaw(i, v)),
        (0u16..12).prop_map(Op::ErrorList),
        (0u16..4).prop_map(Op::Errors),
        (0u16..4).prop_map(Op::Warnings),
        (1u8..=10, 0u8..4).prop_map(|(a, f)| Op::Action(a, f)),
        Just(Op::Quit),
        (0u8..8).prop_map(Op::RaiseError),
        (0..PARAMETERS.len(), 0..3i32).prop_map(|(i, v)| Op::LocalChange(i, v)),
        any::<bool>().prop_map(Op::Air),
        (1u16..3000).prop_map(Op::Wait),
        any::<bool>().prop_map(Op::Disconnect),
    ]
}

fn action(a: u8, f: u8) -> ActionRequest {
    let run = [
        RunFunction::Start,
        RunFunction::Cancel,
        RunFunction::AcknowledgeError,
        RunFunction::Start,
    ][f as usize];
    let go = [
        GoFunction::Approach,
        GoFunction::Adopt,
        GoFunction::Cancel,
        GoFunction::Approach,
    ][f as usize];
    match a {
        1 => ActionRequest::NoInit(
            [
                NoInitFunction::OpenFast,
                NoInitFunction::Stop,
                NoInitFunction::CloseSlow,
                NoInitFunction::EndEvent,
            ][f as usize],
        ),
        2 => ActionRequest::ClearErrorList,
        3 => ActionRequest::SetDefault,
        4 => ActionRequest::InitValve(run),
        5 => ActionRequest::GoClose(go),
        6 => ActionRequest::GoOpen(go),
        7 => ActionRequest::FindFunction(if f == 1 {
            FindFunctionFunction::Cancel
        } else {
            FindFunctionFunction::Activate
        }),
        8 => ActionRequest::AdjustTime(run),
        9 => ActionRequest::FindCoefficient(run),
        _ => ActionRequest::InitPilot(run),
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]
    #[test]
    fn every_request_completes_once(ops in proptest::collection::vec(op(), 1..40)) {
        let mut client = Client::new(ClientConfig { response_timeout: Duration::from_millis(500), action_timeout: Duration::from_secs(30) });
        let mut sim = SimulatedCpos::default();
        let mut now = Instant::ZERO;
        let mut submitted = BTreeSet::new();
        let mut completed = BTreeSet::new();
        let mut connected = true;
        let codes = [0u16, 20, 21, 22, 23, 30, 40, 60];
        let step = |client: &mut Client, sim: &mut SimulatedCpos, now: &mut Instant, connected: bool, completed: &mut BTreeSet<u32>| {
            *now += Duration::from_millis(10);
            if sim.poll_timeout().is_some_and(|t| t <= *now) {
                sim.handle_timeout(*now);
            }
            if connected {
                sim.handle_master_image(*now, &client.image());
                while let Some(d) = sim.poll_diagnostic() {
                    client.handle_diagnostic(*now, d);
                }
                client.handle_image(*now, &sim.device_image());
            }
            if client.poll_timeout().is_some_and(|t| t <= *now) {
                client.handle_timeout(*now);
            }
            while let Some(e) = client.poll_event() {
                if let Event::Completed { id, .. } = e {
                    assert!(completed.insert(id.0), "request {id:?} completed twice");
                }
            }
        };
        for op in ops {
            let r = match op {
                Op::Get(i) => Some(client.get(now, PARAMETERS[i].id)),
                Op::Set(i, v) => Some(client.set(now, PARAMETERS[i].id, v)),
                Op::SetRaw(i, v) => Some(client.set_raw(now, i, v)),
                Op::ErrorList(p) => Some(client.read_error_list(now, p)),
                Op::Errors(n) => Some(client.active_errors(now, n)),
                Op::Warnings(n) => Some(client.active_warnings(now, n)),
                Op::Action(a, f) => Some(client.action(now, action(a, f))),
                Op::Quit => Some(client.quit(now)),
                Op::RaiseError(c) => { sim.raise_error(ErrorCode(codes[c as usize])); None }
                Op::LocalChange(i, v) => { sim.set_local(PARAMETERS[i].id, v); None }
                Op::Air(a) => { sim.set_air_supply(a); None }
                Op::Wait(ms) => {
                    for _ in 0..ms / 10 {
                        step(&mut client, &mut sim, &mut now, connected, &mut completed);
                    }
                    None
                }
                Op::Disconnect(d) => { connected = !d; None }
            };
            if let Some(Ok(id)) = r {
                submitted.insert(id.0);
            }
            step(&mut client, &mut sim, &mut now, connected, &mut completed);
        }
        // Reconnect and let everything finish (quit any action still running).
        connected = true;
        let _ = client.quit(now).map(|id| submitted.insert(id.0));
        for _ in 0..20_000 {
            step(&mut client, &mut sim, &mut now, connected, &mut completed);
            if client.is_idle() && submitted.is_subset(&completed) {
                break;
            }
            if client.active_action().is_some() && client.poll_timeout().is_none() {
                panic!("active action without a deadline");
            }
        }
        prop_assert!(submitted.is_subset(&completed), "lost requests: {:?}", submitted.difference(&completed).collect::<Vec<_>>());
        let _ = (ParamId::MODE, ActionId::InitValve);
    }
}
