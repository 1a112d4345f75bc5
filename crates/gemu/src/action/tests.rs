//! Byte-level tests of the actions against the manual's tables.

use super::*;
use proptest::prelude::*;

fn v(b: [u8; 4]) -> u32 {
    u32::from_be_bytes(b)
}

#[test]
fn action_numbers() {
    for (i, a) in ActionId::ALL.iter().enumerate() {
        assert_eq!(a.to_u16(), i as u16 + 1);
        assert_eq!(ActionId::from_u16(i as u16 + 1), *a);
    }
    assert_eq!(ActionId::InitPilot.to_u16(), 0x0A);
    assert_eq!(ActionId::from_u16(0), ActionId::Unknown(0));
    assert_eq!(ActionId::from_name("init-valve"), Some(ActionId::InitValve));
    assert_eq!(ActionId::from_name("goclose"), Some(ActionId::GoClose));
}

/// 5.6.10 NoInit functions, byte-exact.
#[test]
fn manual_noinit_functions() {
    let pwm = Pwm::new(0x0123).unwrap();
    let cases = [
        (NoInitFunction::Stop, [0x00, 0x00, 0x00, 0x00]),
        (NoInitFunction::OpenSlow, [0x01, 0x00, 0x00, 0x00]),
        (NoInitFunction::OpenFast, [0x02, 0x00, 0x00, 0x00]),
        (NoInitFunction::CloseSlow, [0x03, 0x00, 0x00, 0x00]),
        (NoInitFunction::CloseFast, [0x04, 0x00, 0x00, 0x00]),
        (NoInitFunction::OpenPwm(pwm), [0x05, 0x00, 0x01, 0x23]),
        (NoInitFunction::ClosePwm(pwm), [0x06, 0x00, 0x01, 0x23]),
        (NoInitFunction::EndEvent, [0x07, 0x00, 0x00, 0x00]),
    ];
    for (f, b) in cases {
        assert_eq!(f.to_value(), v(b));
        assert_eq!(NoInitFunction::from_value(v(b)), Some(f));
        assert_eq!(
            ActionRequest::from_parts(ActionId::NoInit, v(b)),
            ActionRequest::NoInit(f)
        );
        // The status is the current function (same coding).
        assert_eq!(
            ActionStatus::decode(ActionId::NoInit, v(b)),
            ActionStatus::NoInit(f)
        );
    }
    assert!(Pwm::new(1001).is_err());
    assert_eq!(
        NoInitFunction::from_value(v([0x05, 0x00, 0x03, 0xE9])),
        None
    );
    assert_eq!(
        NoInitFunction::from_value(v([0x01, 0x00, 0x00, 0x01])),
        None
    );
    assert_eq!(
        NoInitFunction::from_value(v([0x08, 0x00, 0x00, 0x00])),
        None
    );
    // 0x01000000 is "open slowly" for NoInit, never "cannot be started".
    assert_eq!(
        ActionStatus::decode(ActionId::NoInit, 0x0100_0000),
        ActionStatus::NoInit(NoInitFunction::OpenSlow)
    );
}

/// Request values of every action (5.6.11 .. 5.6.19), byte-exact.
#[test]
fn manual_action_requests() {
    use ActionRequest as R;
    let cases = [
        (R::ClearErrorList, 2, [0, 0, 0, 0]),
        (R::SetDefault, 3, [0, 0, 0, 0]),
        (R::InitValve(RunFunction::Start), 4, [0, 0, 0, 1]),
        (R::InitValve(RunFunction::Cancel), 4, [0, 0, 0, 2]),
        (
            R::InitValve(RunFunction::AcknowledgeError),
            4,
            [0, 0, 0xFF, 0],
        ),
        (R::GoClose(GoFunction::Approach), 5, [0, 0, 0, 1]),
        (R::GoClose(GoFunction::Adopt), 5, [0, 0, 0, 2]),
        (R::GoClose(GoFunction::Cancel), 5, [0, 0, 0, 3]),
        (R::GoOpen(GoFunction::Approach), 6, [0, 0, 0, 1]),
        (R::GoOpen(GoFunction::Adopt), 6, [0, 0, 0, 2]),
        (R::GoOpen(GoFunction::Cancel), 6, [0, 0, 0, 3]),
        (
            R::FindFunction(FindFunctionFunction::Activate),
            7,
            [0, 0, 0, 1],
        ),
        (
            R::FindFunction(FindFunctionFunction::Cancel),
            7,
            [0, 0, 0, 2],
        ),
        (R::AdjustTime(RunFunction::Start), 8, [0, 0, 0, 1]),
        (R::AdjustTime(RunFunction::Cancel), 8, [0, 0, 0, 2]),
        (
            R::AdjustTime(RunFunction::AcknowledgeError),
            8,
            [0, 0, 0xFF, 0],
        ),
        (R::FindCoefficient(RunFunction::Start), 9, [0, 0, 0, 1]),
        (R::FindCoefficient(RunFunction::Cancel), 9, [0, 0, 0, 2]),
        (
            R::FindCoefficient(RunFunction::AcknowledgeError),
            9,
            [0, 0, 0xFF, 0],
        ),
        (R::InitPilot(RunFunction::Start), 0x0A, [0, 0, 0, 1]),
        (R::InitPilot(RunFunction::Cancel), 0x0A, [0, 0, 0, 2]),
        (
            R::InitPilot(RunFunction::AcknowledgeError),
            0x0A,
            [0, 0, 0xFF, 0],
        ),
    ];
    for (r, id, b) in cases {
        assert_eq!(r.to_parts(), (ActionId::from_u16(id), v(b)), "{r:?}");
        assert_eq!(ActionRequest::from_parts(ActionId::from_u16(id), v(b)), r);
        // Full channel: [YY, 0x41, 0x00, id, b0..b3].
        let ch = crate::channel::Request::Action {
            action: r.action(),
            value: v(b),
        }
        .to_channel(0x33);
        assert_eq!(
            ch.to_bytes(),
            [0x33, 0x41, 0x00, id as u8, b[0], b[1], b[2], b[3]]
        );
    }
    assert_eq!(
        ActionRequest::from_parts(ActionId::GoOpen, 4),
        ActionRequest::Raw {
            action: ActionId::GoOpen,
            value: 4
        }
    );
}

/// Status values of every action, byte-exact.
#[test]
fn manual_action_statuses() {
    use ActionStatus as S;
    let e22 = ErrorCode::PNEUMATIC;
    let cases: &[(ActionId, [u8; 4], ActionStatus, Phase)] = &[
        (
            ActionId::ClearErrorList,
            [0, 0, 0, 1],
            S::ClearErrorList(DoneStatus::Done),
            Phase::Ended,
        ),
        (
            ActionId::ClearErrorList,
            [0, 0, 0, 2],
            S::ClearErrorList(DoneStatus::NotDone),
            Phase::Running,
        ),
        (
            ActionId::SetDefault,
            [0, 0, 0, 1],
            S::SetDefault(DoneStatus::Done),
            Phase::Ended,
        ),
        (
            ActionId::SetDefault,
            [0, 0, 0, 2],
            S::SetDefault(DoneStatus::NotDone),
            Phase::Running,
        ),
        (
            ActionId::InitValve,
            [0, 0, 0, 0],
            S::InitValve(InitValveStatus::Inactive),
            Phase::Ended,
        ),
        (
            ActionId::InitValve,
            [0, 0, 0, 1],
            S::InitValve(InitValveStatus::ClosedPosition),
            Phase::Running,
        ),
        (
            ActionId::InitValve,
            [0, 0, 0, 2],
            S::InitValve(InitValveStatus::OpenPosition),
            Phase::Running,
        ),
        (
            ActionId::InitValve,
            [0, 0, 0, 3],
            S::InitValve(InitValveStatus::ControlFunction),
            Phase::Running,
        ),
        (
            ActionId::InitValve,
            [0, 0, 0, 4],
            S::InitValve(InitValveStatus::Times),
            Phase::Running,
        ),
        (
            ActionId::InitValve,
            [0, 0, 0, 5],
            S::InitValve(InitValveStatus::Characteristics),
            Phase::Running,
        ),
        (
            ActionId::InitValve,
            [0, 0, 0, 6],
            S::InitValve(InitValveStatus::PilotValves),
            Phase::Running,
        ),
        (
            ActionId::InitValve,
            [0, 0, 0x16, 0xFE],
            S::InitValve(InitValveStatus::ErrorActive(e22)),
            Phase::WaitingForAcknowledge(e22),
        ),
        (
            ActionId::InitValve,
            [0, 0, 0x16, 0xFF],
            S::InitValve(InitValveStatus::ErrorAcknowledged(e22)),
            Phase::EndedWithError(e22),
        ),
        (
            ActionId::InitValve,
            [0, 0, 0x14, 0xFE],
            S::InitValve(InitValveStatus::ErrorActive(ErrorCode::POT_WRONG_DIR)),
            Phase::WaitingForAcknowledge(ErrorCode::POT_WRONG_DIR),
        ),
        (
            ActionId::InitValve,
            [0, 0, 0x14, 0xFF],
            S::InitValve(InitValveStatus::ErrorAcknowledged(ErrorCode::POT_WRONG_DIR)),
            Phase::EndedWithError(ErrorCode::POT_WRONG_DIR),
        ),
        (
            ActionId::InitValve,
            [0, 0, 0x17, 0xFE],
            S::InitValve(InitValveStatus::ErrorActive(ErrorCode::LEAKAGE)),
            Phase::WaitingForAcknowledge(ErrorCode::LEAKAGE),
        ),
        (
            ActionId::InitValve,
            [0, 0, 0x17, 0xFF],
            S::InitValve(InitValveStatus::ErrorAcknowledged(ErrorCode::LEAKAGE)),
            Phase::EndedWithError(ErrorCode::LEAKAGE),
        ),
        (
            ActionId::InitValve,
            [1, 0, 0, 0],
            S::InitValve(InitValveStatus::CannotBeStarted),
            Phase::CannotBeStarted,
        ),
        (
            ActionId::GoClose,
            [0, 0, 0, 1],
            S::GoClose(GoStatus::Approaching),
            Phase::Running,
        ),
        (
            ActionId::GoClose,
            [0, 0, 0, 2],
            S::GoClose(GoStatus::Reached),
            Phase::Ended,
        ),
        (
            ActionId::GoClose,
            [0, 0, 0, 3],
            S::GoClose(GoStatus::Cancelled),
            Phase::Ended,
        ),
        (
            ActionId::GoClose,
            [1, 0, 0, 0],
            S::GoClose(GoStatus::CannotBeStarted),
            Phase::CannotBeStarted,
        ),
        (
            ActionId::GoOpen,
            [0, 0, 0, 1],
            S::GoOpen(GoStatus::Approaching),
            Phase::Running,
        ),
        (
            ActionId::GoOpen,
            [0, 0, 0, 2],
            S::GoOpen(GoStatus::Reached),
            Phase::Ended,
        ),
        (
            ActionId::GoOpen,
            [0, 0, 0, 3],
            S::GoOpen(GoStatus::Cancelled),
            Phase::Ended,
        ),
        (
            ActionId::GoOpen,
            [1, 0, 0, 0],
            S::GoOpen(GoStatus::CannotBeStarted),
            Phase::CannotBeStarted,
        ),
        (
            ActionId::FindFunction,
            [0, 0, 0, 1],
            S::FindFunction(FindFunctionStatus::Inactive),
            Phase::Ended,
        ),
        (
            ActionId::FindFunction,
            [0, 0, 0, 2],
            S::FindFunction(FindFunctionStatus::StartPosition),
            Phase::Running,
        ),
        (
            ActionId::FindFunction,
            [0, 0, 0, 3],
            S::FindFunction(FindFunctionStatus::TestPattern),
            Phase::Running,
        ),
        (
            ActionId::FindFunction,
            [1, 0, 0, 0],
            S::FindFunction(FindFunctionStatus::CannotBeStarted),
            Phase::CannotBeStarted,
        ),
        (
            ActionId::AdjustTime,
            [0, 0, 0, 1],
            S::AdjustTime(AdjustTimeStatus::Inactive),
            Phase::Ended,
        ),
        (
            ActionId::AdjustTime,
            [0, 0, 0, 2],
            S::AdjustTime(AdjustTimeStatus::StartPosition),
            Phase::Running,
        ),
        (
            ActionId::AdjustTime,
            [0, 0, 0, 3],
            S::AdjustTime(AdjustTimeStatus::MeasureClose),
            Phase::Running,
        ),
        (
            ActionId::AdjustTime,
            [0, 0, 0, 4],
            S::AdjustTime(AdjustTimeStatus::MeasureOpen),
            Phase::Running,
        ),
        (
            ActionId::AdjustTime,
            [0, 0, 0x16, 0xFE],
            S::AdjustTime(AdjustTimeStatus::ErrorActive(e22)),
            Phase::WaitingForAcknowledge(e22),
        ),
        (
            ActionId::AdjustTime,
            [0, 0, 0x16, 0xFF],
            S::AdjustTime(AdjustTimeStatus::ErrorAcknowledged(e22)),
            Phase::EndedWithError(e22),
        ),
        (
            ActionId::AdjustTime,
            [1, 0, 0, 0],
            S::AdjustTime(AdjustTimeStatus::CannotBeStarted),
            Phase::CannotBeStarted,
        ),
        (
            ActionId::FindCoefficient,
            [0, 0, 0, 1],
            S::FindCoefficient(FindCoefficientStatus::Inactive),
            Phase::Ended,
        ),
        (
            ActionId::FindCoefficient,
            [0, 0, 7, 2],
            S::FindCoefficient(FindCoefficientStatus::ApproachPoint(7)),
            Phase::Running,
        ),
        (
            ActionId::FindCoefficient,
            [0, 0, 0x16, 0xFE],
            S::FindCoefficient(FindCoefficientStatus::ErrorActive(e22)),
            Phase::WaitingForAcknowledge(e22),
        ),
        (
            ActionId::FindCoefficient,
            [0, 0, 0x16, 0xFF],
            S::FindCoefficient(FindCoefficientStatus::ErrorAcknowledged(e22)),
            Phase::EndedWithError(e22),
        ),
        (
            ActionId::FindCoefficient,
            [1, 0, 0, 0],
            S::FindCoefficient(FindCoefficientStatus::CannotBeStarted),
            Phase::CannotBeStarted,
        ),
        (
            ActionId::InitPilot,
            [0, 0, 0, 1],
            S::InitPilot(InitPilotStatus::Inactive),
            Phase::Ended,
        ),
        (
            ActionId::InitPilot,
            [0, 0, 0, 2],
            S::InitPilot(InitPilotStatus::Active),
            Phase::Running,
        ),
        (
            ActionId::InitPilot,
            [0, 0, 0x16, 0xFE],
            S::InitPilot(InitPilotStatus::ErrorActive(e22)),
            Phase::WaitingForAcknowledge(e22),
        ),
        (
            ActionId::InitPilot,
            [0, 0, 0x16, 0xFF],
            S::InitPilot(InitPilotStatus::ErrorAcknowledged(e22)),
            Phase::EndedWithError(e22),
        ),
        (
            ActionId::InitPilot,
            [0, 0, 0x17, 0xFE],
            S::InitPilot(InitPilotStatus::ErrorActive(ErrorCode::LEAKAGE)),
            Phase::WaitingForAcknowledge(ErrorCode::LEAKAGE),
        ),
        (
            ActionId::InitPilot,
            [0, 0, 0x17, 0xFF],
            S::InitPilot(InitPilotStatus::ErrorAcknowledged(ErrorCode::LEAKAGE)),
            Phase::EndedWithError(ErrorCode::LEAKAGE),
        ),
        (
            ActionId::InitPilot,
            [1, 0, 0, 0],
            S::InitPilot(InitPilotStatus::CannotBeStarted),
            Phase::CannotBeStarted,
        ),
    ];
    for (a, b, s, p) in cases {
        assert_eq!(ActionStatus::decode(*a, v(*b)), *s, "{a:?} {b:?}");
        assert_eq!(s.to_value(), v(*b));
        assert_eq!(s.phase(), *p, "{s:?}");
    }
    assert_eq!(
        ActionStatus::decode(ActionId::GoOpen, 9),
        ActionStatus::Unknown(9)
    );
    assert_eq!(
        ActionStatus::decode(ActionId::Unknown(0x55), 1),
        ActionStatus::Unknown(1)
    );
    assert_eq!(ActionStatus::Unknown(9).phase(), Phase::Unknown);
}

#[test]
fn error_codes() {
    let expected = [
        (0, "NO ERROR"),
        (20, "PotWrongDir"),
        (21, "Wrong Func."),
        (22, "Pneumatic"),
        (23, "Leakage"),
        (30, "Air missing"),
        (40, "Bus Fault"),
        (60, "TrvlSensErr"),
    ];
    for (i, (c, n, m)) in ErrorCode::ALL.iter().enumerate() {
        assert_eq!((c.0, *n), expected[i]);
        assert!(!m.is_empty());
    }
    assert_eq!(ErrorCode(0x14), ErrorCode::POT_WRONG_DIR);
    assert_eq!(ErrorCode(0x1E), ErrorCode::AIR_MISSING);
    assert_eq!(ErrorCode(0x28), ErrorCode::BUS_FAULT);
    assert_eq!(ErrorCode(0x3C), ErrorCode::TRAVEL_SENSOR);
    assert_eq!(ErrorCode(99).name(), None);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]
    #[test]
    fn status_decode_is_lossless(id in 0u16..12, v in any::<u32>()) {
        let a = ActionId::from_u16(id);
        prop_assert_eq!(ActionStatus::decode(a, v).to_value(), v);
    }

    #[test]
    fn request_parts_lossless(id in 0u16..12, v in any::<u32>()) {
        let a = ActionId::from_u16(id);
        prop_assert_eq!(ActionRequest::from_parts(a, v).to_parts(), (a, v));
    }
}
