//! SDO traffic: requests waiting for their answer (late and never answered ones), aborts with
//! their meaning, and answers from two devices of one node-ID.

use super::*;

impl Analyzer {
    pub(super) fn sdo_request(&mut self, line: usize, t: u64, n: u8, frame: &CanFrame) {
        let Ok(req) = ClientRequest::parse(frame.data()) else {
            return;
        };
        if let ClientRequest::Abort { code, .. } = req {
            self.nodes[usize::from(n)].sdo = None;
            let seen = self.seen(frame);
            self.problem(
                t,
                Some(line),
                Some(n),
                Level::Warning,
                Kind::SdoAbort,
                seen,
                format!("the client (master) aborted the transfer: {code}"),
            );
            return;
        }
        let expects_answer = matches!(
            req,
            ClientRequest::InitiateUpload { .. }
                | ClientRequest::InitiateDownload { .. }
                | ClientRequest::UploadSegment { .. }
                | ClientRequest::DownloadSegment(_)
                | ClientRequest::BlockUploadInitiate { .. }
                | ClientRequest::BlockDownloadInitiate { .. }
                | ClientRequest::BlockDownloadEnd { .. }
        );
        if !expects_answer {
            return;
        }
        if let Some((at, l, request)) = self.nodes[usize::from(n)].sdo.take() {
            self.unanswered(n, at, l, &request, "the client sent another request");
        }
        // An SDO write of the heartbeat producer time: the period from then on.
        if let ClientRequest::InitiateDownload {
            mux,
            data: Initiate::Expedited { data, .. },
        } = req
            && (mux.index, mux.subindex) == (0x1017, 0)
        {
            let ms = u64::from(u16::from_le_bytes([data[0], data[1]]));
            let node = &mut self.nodes[usize::from(n)];
            node.period = (ms > 0).then_some(ms * 1000);
            node.first_intervals.clear();
            node.summary.heartbeat_ms = (ms > 0).then_some(ms);
            node.summary.heartbeat_from = (ms > 0).then_some(PeriodSource::SdoWrite);
        }
        self.nodes[usize::from(n)].sdo = Some((t, line, *frame));
    }

    pub(super) fn unanswered(
        &mut self,
        n: u8,
        at: u64,
        line: usize,
        request: &CanFrame,
        why: &str,
    ) {
        let seen = self.seen(request);
        self.problem(
            at,
            Some(line),
            Some(n),
            Level::Error,
            Kind::SdoUnanswered,
            format!("{seen} never answered ({why})"),
            format!(
                "node {n} did not answer: it is absent, not in a state that serves SDO, or the \
                 request was lost"
            ),
        );
    }

    pub(super) fn sdo_response(&mut self, line: usize, t: u64, n: u8, frame: &CanFrame) {
        let Ok(resp) = ServerResponse::parse(frame.data()) else {
            return;
        };
        let timeout = self.config.sdo_timeout_us;
        let node = &mut self.nodes[usize::from(n)];
        let pending = node.sdo.take();
        let initiate = matches!(
            resp,
            ServerResponse::InitiateUpload { .. }
                | ServerResponse::InitiateDownload { .. }
                | ServerResponse::BlockUploadInitiate { .. }
                | ServerResponse::BlockDownloadInitiate { .. }
        );
        let second_answer =
            pending.is_none() && initiate && node.last_answer.is_some_and(|a| t - a < 50_000);
        if initiate {
            node.last_answer = Some(t);
        }
        if let ServerResponse::InitiateUpload {
            mux,
            data: Initiate::Expedited { data, .. },
        } = resp
        {
            let v = u32::from_le_bytes(data);
            match (mux.index, mux.subindex) {
                (0x1018, 1) => node.summary.vendor_id = Some(v),
                (0x1018, 2) => node.summary.product_code = Some(v),
                (0x1000, 0) => node.drive = v & 0xFFFF == 402,
                _ => {}
            }
        }
        let report_twin = second_answer && !node.duplicate_reported;
        if report_twin {
            node.duplicate_reported = true;
        }
        let late = pending.filter(|(at, _, _)| t - at > timeout);
        let abort = match resp {
            ServerResponse::Abort { code, .. } => Some(code),
            _ => None,
        };
        if !report_twin && late.is_none() && abort.is_none() {
            return;
        }
        let seen = self.seen(frame);
        if report_twin {
            self.problem(
                t,
                Some(line),
                Some(n),
                Level::Error,
                Kind::DuplicateNodeId,
                format!("{seen}: a second answer to one SDO request"),
                format!("two devices use node-ID {n}: their SDO answers and PDOs collide"),
            );
        }
        if let Some((at, _, request)) = &late {
            self.problem(
                t,
                Some(line),
                Some(n),
                Level::Warning,
                Kind::SdoLate,
                format!(
                    "{seen}: answered {} ms after the request ({})",
                    (t - at) / 1000,
                    self.seen(request)
                ),
                format!(
                    "slower than {} ms: a client with that timeout aborted the transfer already",
                    timeout / 1000
                ),
            );
        }
        if let Some(code) = abort {
            self.problem(
                t,
                Some(line),
                Some(n),
                Level::Warning,
                Kind::SdoAbort,
                seen,
                format!("node {n} refused the transfer: {code}"),
            );
        }
    }
}
