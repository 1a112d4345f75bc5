//! `network.lss` (python-canopen's `LssMaster`, CiA 305): each call is one service of the
//! facade's LSS master (`Lss::procedure` of one `Step`, or `Lss::fastscan`), and fails with
//! `canola.LssError`.

use canola::lss::service::{IdentifyQuery, Range};
use canola::lss::{
    AddressPart, BitTiming, FastscanConfig, LssAddress, LssError as StackLssError, Mode, Procedure,
    ServiceReport, Step,
};
use canola::{Error, Operation};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

use crate::network::{NetCell, connected};
use crate::wait;

/// The network's LSS master (`network.lss`).
#[pyclass(module = "canola", frozen)]
pub(crate) struct LssMaster {
    net: NetCell,
}

impl LssMaster {
    pub(crate) fn new(net: NetCell) -> Self {
        Self { net }
    }

    /// Runs the service `step` to its end.
    fn run(&self, py: Python<'_>, step: Step) -> PyResult<ServiceReport> {
        let op = connected(&self.net)?
            .lss()
            .procedure(Procedure::single(step));
        wait(py, op)
    }

    /// Runs `step`; `false` when no slave answered in time.
    fn answered(&self, py: Python<'_>, step: Step) -> PyResult<bool> {
        let lss = connected(&self.net)?.lss();
        let op: Operation<'static, bool> = Operation::new(async move {
            match lss.procedure(Procedure::single(step)).await {
                Ok(report) => Ok(report.present.unwrap_or(true)),
                Err(Error::Lss(StackLssError::Timeout { .. })) => Ok(false),
                Err(e) => Err(e),
            }
        });
        wait(py, op)
    }
}

/// The address part a python-canopen inquire command specifier (0x5A..=0x5D) asks for.
fn inquired_part(req_cs: u8) -> PyResult<AddressPart> {
    req_cs
        .checked_sub(0x5A)
        .and_then(AddressPart::from_index)
        .ok_or_else(|| {
            PyValueError::new_err(format!(
                "0x{req_cs:02X} is not an LSS inquire of an address part (0x5A..=0x5D)"
            ))
        })
}

#[pymethods]
impl LssMaster {
    /// LSS waiting state.
    #[classattr]
    const WAITING_STATE: u8 = 0;
    /// LSS configuration state.
    #[classattr]
    const CONFIGURATION_STATE: u8 = 1;

    /// Switches every slave to `mode` (0 waiting, 1 configuration); no answer.
    fn send_switch_state_global(&self, py: Python<'_>, mode: u8) -> PyResult<()> {
        self.run(py, Step::SwitchModeGlobal(Mode::from_raw(mode)))
            .map(drop)
    }

    /// The older name of `send_switch_state_global`.
    fn send_switch_mode_global(&self, py: Python<'_>, mode: u8) -> PyResult<()> {
        self.send_switch_state_global(py, mode)
    }

    /// Switches the slave with this LSS address to configuration state: whether it answered.
    #[allow(non_snake_case)]
    fn send_switch_state_selective(
        &self,
        py: Python<'_>,
        vendorId: u32,
        productCode: u32,
        revisionNumber: u32,
        serialNumber: u32,
    ) -> PyResult<bool> {
        let address = LssAddress::new(vendorId, productCode, revisionNumber, serialNumber);
        self.answered(py, Step::SwitchModeSelective(address))
    }

    /// The node-ID of the slave in configuration state (0xFF: none configured).
    fn inquire_node_id(&self, py: Python<'_>) -> PyResult<u8> {
        let report = self.run(py, Step::InquireNodeId)?;
        report
            .node_id
            .ok_or_else(|| PyValueError::new_err("the inquiry gave no node-ID"))
    }

    /// One part of the LSS address of the slave in configuration state: `req_cs` 0x5A
    /// vendor-ID, 0x5B product code, 0x5C revision number, 0x5D serial number.
    fn inquire_lss_address(&self, py: Python<'_>, req_cs: u8) -> PyResult<u32> {
        let part = inquired_part(req_cs)?;
        let report = self.run(py, Step::InquireIdentity(part))?;
        report.identity[part as usize]
            .ok_or_else(|| PyValueError::new_err("the inquiry gave no value"))
    }

    /// Gives the slave in configuration state the node-ID `new_node_id` (1..=127, or 0xFF
    /// for none); it takes effect when the slave leaves configuration state.
    fn configure_node_id(&self, py: Python<'_>, new_node_id: u8) -> PyResult<()> {
        if !(1..=127).contains(&new_node_id) && new_node_id != 0xFF {
            return Err(PyValueError::new_err(format!(
                "node-ID {new_node_id} is not in 1..=127 (or 0xFF)"
            )));
        }
        self.run(py, Step::ConfigureNodeId(new_node_id)).map(drop)
    }

    /// Sets the bit timing of the slave in configuration state: an index of the CiA table
    /// (0: 1 Mbit/s, 1: 800k, 2: 500k, 3: 250k, 4: 125k, 5: 100k, 6: 50k, 7: 20k, 8: 10k).
    fn configure_bit_timing(&self, py: Python<'_>, new_bit_timing: u8) -> PyResult<()> {
        let timing = BitTiming {
            table: BitTiming::CIA_TABLE,
            index: new_bit_timing,
        };
        self.run(py, Step::ConfigureBitTiming(timing)).map(drop)
    }

    /// Makes every slave switch to the configured bit timing after `switch_delay_ms`; waits
    /// twice the delay.
    fn activate_bit_timing(&self, py: Python<'_>, switch_delay_ms: u16) -> PyResult<()> {
        self.run(
            py,
            Step::ActivateBitTiming {
                delay_ms: switch_delay_ms,
            },
        )
        .map(drop)
    }

    /// Makes the slave in configuration state store its configuration.
    fn store_configuration(&self, py: Python<'_>) -> PyResult<()> {
        let report = self.run(py, Step::StoreConfiguration)?;
        if report.stored == Some(false) {
            return Err(LssError::new_err(
                "the LSS slave does not support store configuration",
            ));
        }
        Ok(())
    }

    /// Whether a slave with this vendor-ID, product code and revision and serial number in
    /// these ranges answers.
    #[allow(non_snake_case, clippy::too_many_arguments)]
    fn send_identify_remote_slave(
        &self,
        py: Python<'_>,
        vendorId: u32,
        productCode: u32,
        revisionNumberLow: u32,
        revisionNumberHigh: u32,
        serialNumberLow: u32,
        serialNumberHigh: u32,
    ) -> PyResult<bool> {
        let query = IdentifyQuery {
            vendor_id: vendorId,
            product_code: productCode,
            revision: Range {
                low: revisionNumberLow,
                high: revisionNumberHigh,
            },
            serial: Range {
                low: serialNumberLow,
                high: serialNumberHigh,
            },
        };
        self.answered(py, Step::IdentifyRemoteSlave(query))
    }

    /// Whether a slave without a node-ID answers.
    fn send_identify_non_configured_remote_slave(&self, py: Python<'_>) -> PyResult<bool> {
        self.answered(py, Step::IdentifyNonConfigured)
    }

    /// CiA 305 Fastscan: `(True, [vendor_id, product_code, revision_number, serial_number])`
    /// of the slave found (it is then in configuration state), or `(False, None)`.
    fn fast_scan(&self, py: Python<'_>) -> PyResult<(bool, Option<Vec<u32>>)> {
        let op = connected(&self.net)?
            .lss()
            .fastscan(FastscanConfig::default());
        Ok(match wait(py, op)? {
            Some(a) => (
                true,
                Some(vec![
                    a.vendor_id,
                    a.product_code,
                    a.revision_number,
                    a.serial_number,
                ]),
            ),
            None => (false, None),
        })
    }

    fn __repr__(&self) -> String {
        "<canola.LssMaster>".into()
    }
}

pyo3::create_exception!(
    canola,
    LssError,
    pyo3::exceptions::PyException,
    "An LSS service failed: no answer, or the slave refused it."
);
