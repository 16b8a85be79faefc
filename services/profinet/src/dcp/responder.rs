//! The device side of DCP: answers Identify, Get and Set, and keeps the station parameters.
//!
//! The station parameters exist three times: the factory values (from the configuration),
//! the permanent ones (in the [`PermanentStore`], surviving a restart) and the current ones
//! (what the device reports and uses). A Set with BlockQualifier bit 0 clear changes only the
//! current value (temporary); with it set, the permanent value too. A temporary IP also
//! deletes the stored one, as field devices do: after a power cycle the station has no IP
//! until a controller assigns one (an S7 assigns it temporarily at every start-up). Reset to
//! factory erases the store and returns to the factory values; the device holds no
//! application data in DCP, so every reset mode does exactly that.
//!
//! An IP parameter takes effect on the interface through the [`IpInterface`] port before
//! the Set is answered, so the answer says whether the address is really in use: one the
//! interface refuses (the process lacks CAP_NET_ADMIN, say) is answered with BlockError 5
//! "SET not possible by local reasons" and the station keeps its previous IP. At start the
//! IP in use (the permanent or the factory one) is applied when one is set; an unset one
//! leaves the interface as it is, since the address may be configured outside the device
//! until a controller assigns one. A Set of 0.0.0.0, and reset to factory to an unset IP,
//! remove the address.

use std::time::Duration;

use super::block::{self, Block, BlockError, BlockType, BlockWriter};
use super::delay::ResponseSpread;
use super::station::{
    DeviceIdentity, IpInterface, IpParameter, NameOfStation, PermanentStore, StationParameters,
};
use super::{DcpError, DcpHeader, HEADER_LEN, ServiceId, ServiceType};
use crate::ethernet::{
    ETHER_TYPE_PROFINET, EthernetHeader, MacAddress, UNTAGGED_HEADER_LEN, pad_to_minimum,
};
use crate::frame_id::{self, FrameUse};

/// The blocks an Identify response carries, in p-net's order (which tools expect).
const IDENTIFY_BLOCKS: [BlockType; 7] = [
    block::IP_PARAMETER,
    block::TYPE_OF_STATION,
    block::NAME_OF_STATION,
    block::DEVICE_ID,
    block::DEVICE_ROLE,
    block::DEVICE_OPTIONS,
    block::DEVICE_INSTANCE,
];

/// The Control blocks this device supports (with the MAC address and the Identify
/// blocks, what DeviceOptions lists).
const CONTROL_BLOCKS: [BlockType; 6] = [
    block::CONTROL_START,
    block::CONTROL_STOP,
    block::CONTROL_SIGNAL,
    block::CONTROL_RESPONSE,
    block::CONTROL_FACTORY_RESET,
    block::CONTROL_RESET_TO_FACTORY,
];
/// Number of blocks DeviceOptions lists.
const SUPPORTED_COUNT: usize = 1 + IDENTIFY_BLOCKS.len() + CONTROL_BLOCKS.len();

/// BlockInfo of the IP parameter: an address is set (statically).
const IP_SET: u16 = 0x0001;
/// BlockQualifier bit 0: store the value permanently.
const QUALIFIER_PERMANENT: u16 = 0x0001;

/// What the shell must do after a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct DcpOutcome {
    /// The response: `len` bytes at the start of the output buffer, to be sent after `delay`.
    pub reply: Option<DcpReply>,
    /// A Signal asked the device to flash its identification LED.
    pub signal: bool,
    /// The current station parameters changed (the shell may reconfigure its interface).
    pub changed: bool,
}

/// A response frame to send.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DcpReply {
    /// Length of the frame in the output buffer.
    pub len: usize,
    /// Wait this long before sending (the Identify response spread).
    pub delay: Duration,
}

/// The device's DCP state machine.
#[derive(Debug)]
pub struct DcpResponder<S: PermanentStore, I: IpInterface> {
    identity: DeviceIdentity,
    factory: StationParameters,
    permanent: StationParameters,
    current: StationParameters,
    store: S,
    interface: I,
    spread: ResponseSpread,
}

impl<S: PermanentStore, I: IpInterface> DcpResponder<S, I> {
    /// A responder starting from the permanent values in `store`, or from `factory` when
    /// the store holds none or cannot be read (logged: the device must come up anyway);
    /// the IP in use is applied to `interface` when one is set (a failure is logged, and
    /// the device still reports the IP, as a controller's next Set may fix it).
    pub fn new(
        identity: DeviceIdentity,
        factory: StationParameters,
        mut store: S,
        mut interface: I,
    ) -> Self {
        let permanent = match store.load() {
            Ok(Some(stored)) => stored,
            Ok(None) => factory.clone(),
            Err(error) => {
                tracing::warn!(%error, "permanent station parameters unreadable; using the factory values");
                factory.clone()
            }
        };
        if permanent.ip.is_set()
            && let Err(error) = interface.apply(&permanent.ip)
        {
            tracing::error!(%error, ip = %permanent.ip.address, "the station's IP is not applied at start");
        }
        Self {
            spread: ResponseSpread::new(identity.mac),
            identity,
            current: permanent.clone(),
            permanent,
            factory,
            store,
            interface,
        }
    }

    /// The station parameters in use.
    pub fn current(&self) -> &StationParameters {
        &self.current
    }

    /// The station parameters that survive a restart.
    pub fn permanent(&self) -> &StationParameters {
        &self.permanent
    }

    /// The device's identity.
    pub fn identity(&self) -> &DeviceIdentity {
        &self.identity
    }

    /// Handles one received frame; a response is written to the start of `out`
    /// ([`crate::ethernet::MAX_FRAME_LEN`] bytes always suffice). Frames that are not DCP
    /// requests for this device are ignored.
    pub fn handle(&mut self, frame: &[u8], out: &mut [u8]) -> Result<DcpOutcome, DcpError> {
        let Ok((ethernet, payload)) = EthernetHeader::parse(frame) else {
            return Ok(DcpOutcome::default());
        };
        let for_us = ethernet.destination == self.identity.mac
            || ethernet.destination == MacAddress::DCP_IDENTIFY;
        if ethernet.ether_type != ETHER_TYPE_PROFINET
            || !for_us
            || ethernet.source == self.identity.mac
            || payload.len() < 2
        {
            return Ok(DcpOutcome::default());
        }
        let frame_id = u16::from_be_bytes([payload[0], payload[1]]);
        let frame_use = frame_id::frame_use(frame_id);
        let unicast = ethernet.destination == self.identity.mac;
        let addressed = match frame_use {
            FrameUse::DcpIdentifyRequest => true,
            FrameUse::DcpGetSet => unicast,
            _ => false,
        };
        if !addressed {
            return Ok(DcpOutcome::default());
        }
        let (header, data) = DcpHeader::parse(&payload[2..])?;
        let fits = matches!(
            (frame_use, header.service_id),
            (FrameUse::DcpIdentifyRequest, ServiceId::Identify)
                | (FrameUse::DcpGetSet, ServiceId::Get | ServiceId::Set)
        );
        if header.service_type != ServiceType::Request || !fits {
            return Ok(DcpOutcome::default());
        }
        let mut outcome = DcpOutcome::default();
        let body_at = UNTAGGED_HEADER_LEN + 2 + HEADER_LEN;
        let have = out.len();
        let body = out.get_mut(body_at..).ok_or(DcpError::BufferTooSmall {
            need: body_at,
            have,
        })?;
        let mut writer = BlockWriter::new(body);
        let (response_frame_id, delay) = match header.service_id {
            ServiceId::Identify => {
                if !self.matches(data)? {
                    return Ok(outcome);
                }
                for block_type in IDENTIFY_BLOCKS {
                    self.write_block(&mut writer, block_type)?;
                }
                let delay = self.spread.delay(header.response_delay);
                (frame_id::DCP_IDENTIFY_RESPONSE, delay)
            }
            ServiceId::Get => {
                // A Get carries bare Option/Suboption pairs.
                for pair in data.chunks_exact(2) {
                    let block_type = BlockType {
                        option: pair[0],
                        suboption: pair[1],
                    };
                    if !self.write_block(&mut writer, block_type)? {
                        writer.control_response(block_type, unsupported(block_type))?;
                    }
                }
                (frame_id::DCP_GET_SET, Duration::ZERO)
            }
            ServiceId::Set => {
                for request in block::blocks(data) {
                    let request = request?;
                    let error = self.set(&request, &mut outcome);
                    writer.control_response(request.block_type, error)?;
                }
                (frame_id::DCP_GET_SET, Duration::ZERO)
            }
            // Excluded by `fits` above.
            ServiceId::Hello => return Ok(outcome),
        };
        let data_len = writer.len();
        let response = DcpHeader {
            service_id: header.service_id,
            service_type: ServiceType::ResponseSuccess,
            xid: header.xid,
            response_delay: 0,
            data_length: u16::try_from(data_len).map_err(|_| DcpError::BufferTooSmall {
                need: data_len,
                have: usize::from(u16::MAX),
            })?,
        };
        let reply_header = EthernetHeader {
            destination: ethernet.source,
            source: self.identity.mac,
            vlan: None,
            ether_type: ETHER_TYPE_PROFINET,
        };
        let at = reply_header
            .write(out)
            .map_err(|_| DcpError::BufferTooSmall {
                need: body_at,
                have: out.len(),
            })?;
        out[at..at + 2].copy_from_slice(&response_frame_id.to_be_bytes());
        response.write(&mut out[at + 2..])?;
        let len = pad_to_minimum(out, body_at + data_len);
        outcome.reply = Some(DcpReply { len, delay });
        Ok(outcome)
    }

    /// True when every filter block of an Identify request matches this device.
    fn matches(&self, filters: &[u8]) -> Result<bool, DcpError> {
        let mut any = false;
        for filter in block::blocks(filters) {
            let filter = filter?;
            any = true;
            let value = filter.value;
            let matched = match filter.block_type {
                block::ALL_SELECTOR => true,
                block::NAME_OF_STATION => {
                    let name = self.current.name_of_station.as_str().as_bytes();
                    !name.is_empty() && value.eq_ignore_ascii_case(name)
                }
                block::TYPE_OF_STATION => value == self.identity.type_of_station.as_bytes(),
                block::DEVICE_ID => value == self.device_id_value(),
                block::DEVICE_ROLE => value
                    .first()
                    .is_some_and(|role| role & block::DEVICE_ROLE_IO_DEVICE != 0),
                block::DEVICE_INSTANCE => value == self.identity.device_instance.to_be_bytes(),
                block::IP_PARAMETER => value == self.current.ip.to_wire(),
                _ => false,
            };
            if !matched {
                return Ok(false);
            }
        }
        Ok(any)
    }

    /// Writes the block `block_type` as Identify and Get report it; false if unsupported.
    fn write_block(
        &self,
        writer: &mut BlockWriter<'_>,
        block_type: BlockType,
    ) -> Result<bool, DcpError> {
        let identity = &self.identity;
        match block_type {
            block::MAC_ADDRESS => writer.block(block_type, 0, &[&identity.mac.0])?,
            block::IP_PARAMETER => {
                let info = if self.current.ip.is_set() { IP_SET } else { 0 };
                writer.block(block_type, info, &[&self.current.ip.to_wire()])?;
            }
            block::TYPE_OF_STATION => {
                writer.block(block_type, 0, &[identity.type_of_station.as_bytes()])?
            }
            block::NAME_OF_STATION => writer.block(
                block_type,
                0,
                &[self.current.name_of_station.as_str().as_bytes()],
            )?,
            block::DEVICE_ID => writer.block(block_type, 0, &[&self.device_id_value()])?,
            block::DEVICE_ROLE => {
                writer.block(block_type, 0, &[&[block::DEVICE_ROLE_IO_DEVICE, 0]])?
            }
            block::DEVICE_OPTIONS => {
                let supported = std::iter::once(block::MAC_ADDRESS)
                    .chain(IDENTIFY_BLOCKS)
                    .chain(CONTROL_BLOCKS);
                let mut options = [0u8; 2 * SUPPORTED_COUNT];
                for (pair, supported) in options.chunks_exact_mut(2).zip(supported) {
                    pair.copy_from_slice(&[supported.option, supported.suboption]);
                }
                writer.block(block_type, 0, &[&options])?;
            }
            block::DEVICE_INSTANCE => {
                writer.block(block_type, 0, &[&identity.device_instance.to_be_bytes()])?
            }
            _ => return Ok(false),
        }
        Ok(true)
    }

    fn device_id_value(&self) -> [u8; 4] {
        let [v0, v1] = self.identity.vendor_id.to_be_bytes();
        let [d0, d1] = self.identity.device_id.to_be_bytes();
        [v0, v1, d0, d1]
    }

    /// Carries out one block of a Set request.
    fn set(&mut self, request: &Block<'_>, outcome: &mut DcpOutcome) -> BlockError {
        let Some((qualifier, value)) = request.qualified() else {
            return BlockError::SetNotPossible;
        };
        let permanent = qualifier & QUALIFIER_PERMANENT != 0;
        match request.block_type {
            block::CONTROL_START | block::CONTROL_STOP => BlockError::NoError,
            block::CONTROL_SIGNAL => {
                if value == block::SIGNAL_FLASH_ONCE.to_be_bytes() {
                    outcome.signal = true;
                    BlockError::NoError
                } else {
                    BlockError::SetNotPossible
                }
            }
            block::NAME_OF_STATION => match NameOfStation::new(value) {
                Ok(name) => self.assign(permanent, outcome, |p| p.name_of_station = name.clone()),
                Err(error) => {
                    tracing::info!(%error, "DCP Set NameOfStation refused");
                    BlockError::SetNotPossible
                }
            },
            block::IP_PARAMETER => match IpParameter::from_wire(value) {
                Ok(Some(ip)) => self.set_ip(ip, permanent, outcome),
                Ok(None) => BlockError::SetNotPossible,
                Err(error) => {
                    tracing::info!(%error, "DCP Set IP refused");
                    BlockError::SetNotPossible
                }
            },
            block::CONTROL_RESET_TO_FACTORY | block::CONTROL_FACTORY_RESET => {
                self.reset_to_factory(outcome)
            }
            other => unsupported(other),
        }
    }

    /// Applies `change` to the current parameters and, if `permanent`, to the stored ones
    /// (stored first: a failing store leaves everything as it was).
    fn assign(
        &mut self,
        permanent: bool,
        outcome: &mut DcpOutcome,
        change: impl Fn(&mut StationParameters),
    ) -> BlockError {
        if permanent {
            let error = self.store_permanent(&change);
            if error != BlockError::NoError {
                return error;
            }
        }
        let before = self.current.clone();
        change(&mut self.current);
        outcome.changed |= self.current != before;
        BlockError::NoError
    }

    /// Applies `ip` to the interface (also when it is the IP in use: the interface may
    /// not have it, after a refusal at start, say), then keeps it as [`Self::assign`]
    /// does; when the interface refuses it nothing changes, and when storing fails the
    /// previous IP goes back onto the interface.
    fn set_ip(&mut self, ip: IpParameter, permanent: bool, outcome: &mut DcpOutcome) -> BlockError {
        let previous = self.current.ip;
        if !self.apply_ip(&ip) {
            return BlockError::SetNotPossible;
        }
        // A temporary IP deletes the stored one first.
        let error = match permanent || !self.permanent.ip.is_set() {
            true => BlockError::NoError,
            false => self.store_permanent(|p| p.ip = IpParameter::UNSET),
        };
        let error = match error {
            BlockError::NoError => self.assign(permanent, outcome, |p| p.ip = ip),
            error => error,
        };
        if error != BlockError::NoError && ip != previous {
            self.apply_ip(&previous);
        }
        error
    }

    /// Applies `change` to the stored parameters; a failing store leaves them as they were.
    fn store_permanent(&mut self, change: impl Fn(&mut StationParameters)) -> BlockError {
        let mut stored = self.permanent.clone();
        change(&mut stored);
        if let Err(error) = self.store.save(&stored) {
            tracing::warn!(%error, "cannot store the permanent station parameters");
            return BlockError::ResourceError;
        }
        self.permanent = stored;
        BlockError::NoError
    }

    /// Applies `ip` to the interface; false (logged) when the interface refuses it.
    fn apply_ip(&mut self, ip: &IpParameter) -> bool {
        match self.interface.apply(ip) {
            Ok(()) => true,
            Err(error) => {
                tracing::error!(%error, ip = %ip.address, "DCP Set IP not applied to the interface");
                false
            }
        }
    }

    fn reset_to_factory(&mut self, outcome: &mut DcpOutcome) -> BlockError {
        // The factory IP goes onto the interface first: a refusal keeps everything.
        let (previous, factory) = (self.current.ip, self.factory.ip);
        if factory != previous && !self.apply_ip(&factory) {
            return BlockError::SetNotPossible;
        }
        if let Err(error) = self.store.erase() {
            tracing::warn!(%error, "cannot erase the permanent station parameters");
            if factory != previous {
                self.apply_ip(&previous);
            }
            return BlockError::ResourceError;
        }
        outcome.changed |= self.current != self.factory;
        self.permanent = self.factory.clone();
        self.current = self.factory.clone();
        BlockError::NoError
    }
}

/// The BlockError for a block this device does not support.
fn unsupported(block_type: BlockType) -> BlockError {
    match block_type.option {
        1 | 2 | 5 => BlockError::SuboptionNotSupported,
        _ => BlockError::OptionNotSupported,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dcp::station::MemoryStore;
    use crate::ethernet::MAX_FRAME_LEN;
    use crate::testdata;
    use proptest::prelude::*;
    use std::net::Ipv4Addr;

    const DEVICE: MacAddress = MacAddress([0x8c, 0xf3, 0x19, 0xcd, 0x19, 0xf8]);
    const PLC: MacAddress = MacAddress([0xec, 0x1c, 0x5d, 0x61, 0xe7, 0x3f]);

    fn identity() -> DeviceIdentity {
        DeviceIdentity {
            mac: DEVICE,
            vendor_id: 0x0493,
            device_id: 0x0002,
            device_instance: 0x0001,
            type_of_station: "P-Net Sample Application".into(),
        }
    }

    fn named(name: &str) -> StationParameters {
        StationParameters {
            name_of_station: NameOfStation::new(name.as_bytes()).unwrap(),
            ip: IpParameter::UNSET,
        }
    }

    /// The interface as the tests see it: what was applied, and whether it refuses.
    #[derive(Debug, Default)]
    struct FakeInterface {
        applied: Vec<IpParameter>,
        refuse: bool,
    }

    impl IpInterface for FakeInterface {
        type Error = std::io::Error;
        fn apply(&mut self, ip: &IpParameter) -> Result<(), Self::Error> {
            if self.refuse {
                return Err(std::io::Error::from(std::io::ErrorKind::PermissionDenied));
            }
            self.applied.push(*ip);
            Ok(())
        }
    }

    fn responder(name: &str) -> DcpResponder<MemoryStore, FakeInterface> {
        DcpResponder::new(
            identity(),
            named(name),
            MemoryStore::default(),
            FakeInterface::default(),
        )
    }

    /// A DCP request frame from the PLC.
    fn request(
        destination: MacAddress,
        frame_id: u16,
        service: u8,
        response_delay: u16,
        data: &[u8],
    ) -> Vec<u8> {
        let mut frame = Vec::new();
        frame.extend_from_slice(&destination.0);
        frame.extend_from_slice(&PLC.0);
        frame.extend_from_slice(&[0x88, 0x92]);
        frame.extend_from_slice(&frame_id.to_be_bytes());
        frame.extend_from_slice(&[service, 0, 0x12, 0x34, 0x56, 0x78]);
        frame.extend_from_slice(&response_delay.to_be_bytes());
        frame.extend_from_slice(&(data.len() as u16).to_be_bytes());
        frame.extend_from_slice(data);
        frame
    }

    fn set(data: &[u8]) -> Vec<u8> {
        request(DEVICE, frame_id::DCP_GET_SET, 4, 0, data)
    }

    fn set_name(name: &[u8], qualifier: u16) -> Vec<u8> {
        let mut data = vec![2, 2];
        data.extend_from_slice(&(name.len() as u16 + 2).to_be_bytes());
        data.extend_from_slice(&qualifier.to_be_bytes());
        data.extend_from_slice(name);
        if data.len() % 2 == 1 {
            data.push(0);
        }
        set(&data)
    }

    fn handle<S: PermanentStore>(
        responder: &mut DcpResponder<S, FakeInterface>,
        frame: &[u8],
    ) -> (DcpOutcome, Vec<u8>) {
        let mut out = [0u8; MAX_FRAME_LEN];
        let outcome = responder.handle(frame, &mut out).unwrap();
        let len = outcome.reply.map_or(0, |reply| reply.len);
        (outcome, out[..len].to_vec())
    }

    /// The Control/Response blocks of a Set response: (option, suboption, error).
    fn block_errors(reply: &[u8]) -> Vec<(u8, u8, u8)> {
        let (_, payload) = EthernetHeader::parse(reply).unwrap();
        let (_, data) = DcpHeader::parse(&payload[2..]).unwrap();
        block::blocks(data)
            .map(|b| {
                let b = b.unwrap();
                assert_eq!(b.block_type, block::CONTROL_RESPONSE);
                (b.value[0], b.value[1], b.value[2])
            })
            .collect()
    }

    #[test]
    fn the_identify_response_reproduces_the_golden_p_net_blocks() {
        let mut device = responder("rt-labs-dev");
        let golden = testdata::frame("ident_ok_pnet");
        let mut frame = request(MacAddress::DCP_IDENTIFY, 0xfefe, 5, 0, &[0xff, 0xff, 0, 0]);
        frame[18..22].copy_from_slice(&golden[18..22]); // the golden Xid
        let (outcome, reply) = handle(&mut device, &frame);
        assert_eq!(outcome.reply.unwrap().delay, Duration::ZERO);
        // Same Ethernet header, FrameID, service, Xid.
        assert_eq!(reply[..22], golden[..22]);
        // Every golden block but DeviceOptions (ours lists what we support) and DeviceRole
        // (p-net sets its reserved byte, we send 0) is identical.
        let ours = block_values(&reply);
        for (block_type, value) in block_values(&golden) {
            match block_type {
                block::DEVICE_OPTIONS => {}
                block::DEVICE_ROLE => assert_eq!(value[..3], [0, 0, block::DEVICE_ROLE_IO_DEVICE]),
                _ => assert!(
                    ours.contains(&(block_type, value.clone())),
                    "{block_type:?}"
                ),
            }
        }
        assert!(ours.contains(&(block::DEVICE_ROLE, vec![0, 0, 1, 0])));
        let (_, options) = ours
            .iter()
            .find(|(t, _)| *t == block::DEVICE_OPTIONS)
            .unwrap();
        let pairs: Vec<&[u8]> = options[2..].chunks(2).collect();
        assert_eq!(pairs.len(), 14);
        for pair in [[1, 1], [1, 2], [2, 2], [2, 7], [5, 3], [5, 6]] {
            assert!(pairs.contains(&&pair[..]), "{pair:?} not in DeviceOptions");
        }
        assert!(
            ours.iter()
                .any(|(t, v)| *t == block::DEVICE_INSTANCE && v == &[0, 0, 0, 1])
        );
    }

    fn block_values(frame: &[u8]) -> Vec<(BlockType, Vec<u8>)> {
        let (_, payload) = EthernetHeader::parse(frame).unwrap();
        let (_, data) = DcpHeader::parse(&payload[2..]).unwrap();
        block::blocks(data)
            .map(|b| b.map(|b| (b.block_type, b.value.to_vec())).unwrap())
            .collect()
    }

    #[test]
    fn the_golden_identify_by_name_is_answered_only_by_that_name() {
        let golden = testdata::frame("identify_req_s7");
        let (outcome, _) = handle(&mut responder("other-device"), &golden);
        assert_eq!(outcome.reply, None);
        let (outcome, reply) = handle(&mut responder("i-device"), &golden);
        assert!(outcome.reply.is_some());
        assert_eq!(&reply[0..6], &golden[6..12]);
        assert_eq!(&reply[6..12], &DEVICE.0);
        assert_eq!(&reply[14..16], &[0xfe, 0xff]);
        assert_eq!(&reply[18..22], &golden[18..22]);
        // A device without a name is not found by an empty name either.
        let unnamed = request(MacAddress::DCP_IDENTIFY, 0xfefe, 5, 0, &[2, 2, 0, 0]);
        assert_eq!(handle(&mut responder(""), &unnamed).0.reply, None);
    }

    #[test]
    fn identify_filters_must_all_match() {
        let mut device = responder("rc-robot");
        let identify = |data: &[u8]| request(MacAddress::DCP_IDENTIFY, 0xfefe, 5, 0, data);
        let by_id = identify(&[2, 3, 0, 4, 0x04, 0x93, 0x00, 0x02]);
        assert!(handle(&mut device, &by_id).0.reply.is_some());
        let wrong_id = identify(&[2, 3, 0, 4, 0x04, 0x93, 0x00, 0x03]);
        assert_eq!(handle(&mut device, &wrong_id).0.reply, None);
        let name_and_wrong_id = identify(&[
            2, 2, 0, 8, b'r', b'c', b'-', b'r', b'o', b'b', b'o', b't', 2, 3, 0, 4, 0, 0, 0, 0,
        ]);
        assert_eq!(handle(&mut device, &name_and_wrong_id).0.reply, None);
        assert_eq!(handle(&mut device, &identify(&[])).0.reply, None);
        assert_eq!(handle(&mut device, &identify(&[2, 6, 0, 0])).0.reply, None);
    }

    #[test]
    fn an_identify_all_is_spread_over_the_response_delay() {
        let mut device = responder("rc-robot");
        let frame = request(
            MacAddress::DCP_IDENTIFY,
            0xfefe,
            5,
            128,
            &[0xff, 0xff, 0, 0],
        );
        let delays: Vec<Duration> = (0..16)
            .map(|_| handle(&mut device, &frame).0.reply.unwrap().delay)
            .collect();
        assert!(delays.iter().all(|d| *d <= Duration::from_millis(1270)));
        assert!(delays.iter().any(|d| !d.is_zero()));
    }

    #[test]
    fn the_golden_set_ip_is_answered_like_p_net() {
        let mut device = responder("rt-labs-dev");
        let (outcome, reply) = handle(&mut device, &testdata::frame("dcp_set_req"));
        assert!(outcome.changed);
        let golden = testdata::frame("dcp_set_res");
        // p-net sends 34 bytes; we pad to the Ethernet minimum.
        assert_eq!(reply[..golden.len()], golden[..]);
        assert!(reply[golden.len()..].iter().all(|&b| b == 0));
        assert_eq!(reply.len(), 60);
        assert_eq!(
            device.current().ip,
            IpParameter {
                address: Ipv4Addr::new(172, 16, 2, 10),
                subnet_mask: Ipv4Addr::new(255, 255, 255, 0),
                gateway: Ipv4Addr::new(172, 16, 2, 10),
            }
        );
        // Temporary: the permanent value is still the factory one.
        assert_eq!(device.permanent().ip, IpParameter::UNSET);
    }

    #[test]
    fn a_permanent_name_is_stored_and_comes_back_after_a_restart() {
        let mut device = responder("factory-name");
        let (outcome, reply) = handle(&mut device, &set_name(b"cell1-robot", 1));
        assert_eq!(block_errors(&reply), [(2, 2, 0)]);
        assert!(outcome.changed);
        assert_eq!(device.current().name_of_station.as_str(), "cell1-robot");
        let store = MemoryStore {
            stored: Some(device.permanent().clone()),
        };
        let restarted = DcpResponder::new(
            identity(),
            named("factory-name"),
            store,
            FakeInterface::default(),
        );
        assert_eq!(restarted.current().name_of_station.as_str(), "cell1-robot");
    }

    #[test]
    fn a_temporary_name_is_not_stored() {
        let mut device = responder("factory-name");
        let (outcome, reply) = handle(&mut device, &set_name(b"temp", 0));
        assert_eq!(block_errors(&reply), [(2, 2, 0)]);
        assert!(outcome.changed);
        assert_eq!(device.current().name_of_station.as_str(), "temp");
        assert_eq!(device.permanent().name_of_station.as_str(), "factory-name");
        assert_eq!(device.store.stored, None);
        // The same name again changes nothing.
        assert!(!handle(&mut device, &set_name(b"temp", 0)).0.changed);
    }

    #[test]
    fn an_invalid_name_is_refused_and_changes_nothing() {
        let mut device = responder("rc-robot");
        let (outcome, reply) = handle(&mut device, &set_name(b"Bad Name", 1));
        assert_eq!(block_errors(&reply), [(2, 2, 5)]);
        assert!(!outcome.changed);
        assert_eq!(device.current().name_of_station.as_str(), "rc-robot");
    }

    #[derive(Debug)]
    struct BrokenStore;

    impl PermanentStore for BrokenStore {
        type Error = std::io::Error;
        fn load(&mut self) -> Result<Option<StationParameters>, Self::Error> {
            Err(std::io::Error::other("disk gone"))
        }
        fn save(&mut self, _: &StationParameters) -> Result<(), Self::Error> {
            Err(std::io::Error::other("disk gone"))
        }
        fn erase(&mut self) -> Result<(), Self::Error> {
            Err(std::io::Error::other("disk gone"))
        }
    }

    #[test]
    fn a_failing_store_is_a_resource_error_and_leaves_the_values() {
        let mut device = DcpResponder::new(
            identity(),
            named("rc-robot"),
            BrokenStore,
            FakeInterface::default(),
        );
        assert_eq!(device.current().name_of_station.as_str(), "rc-robot");
        let (outcome, reply) = handle(&mut device, &set_name(b"other", 1));
        assert_eq!(block_errors(&reply), [(2, 2, 4)]);
        assert!(!outcome.changed);
        assert_eq!(device.current().name_of_station.as_str(), "rc-robot");
        let (_, reply) = handle(&mut device, &set(&[5, 6, 0, 2, 0, 4]));
        assert_eq!(block_errors(&reply), [(5, 6, 4)]);
    }

    #[test]
    fn reset_to_factory_erases_the_store_and_restores_the_factory_values() {
        let mut device = responder("factory-name");
        handle(&mut device, &set_name(b"cell1-robot", 1));
        let (outcome, reply) = handle(&mut device, &set(&[5, 6, 0, 2, 0, 4]));
        assert_eq!(block_errors(&reply), [(5, 6, 0)]);
        assert!(outcome.changed);
        assert_eq!(device.current().name_of_station.as_str(), "factory-name");
        assert_eq!(device.store.stored, None);
        let (_, reply) = handle(&mut device, &set(&[5, 5, 0, 2, 0, 0]));
        assert_eq!(block_errors(&reply), [(5, 5, 0)]);
    }

    /// A Set of the IP parameter `ip` with `qualifier`.
    fn set_ip(ip: IpParameter, qualifier: u16) -> Vec<u8> {
        let mut data = vec![1, 2, 0, 14];
        data.extend_from_slice(&qualifier.to_be_bytes());
        data.extend_from_slice(&ip.to_wire());
        set(&data)
    }

    const CELL_IP: IpParameter = IpParameter {
        address: Ipv4Addr::new(10, 0, 0, 5),
        subnet_mask: Ipv4Addr::new(255, 255, 255, 0),
        gateway: Ipv4Addr::new(10, 0, 0, 1),
    };

    #[test]
    fn a_set_ip_is_applied_to_the_interface_before_it_is_answered() {
        let mut device = responder("rc-robot");
        assert!(
            device.interface.applied.is_empty(),
            "an unset IP is not applied at start"
        );
        let (outcome, reply) = handle(&mut device, &set_ip(CELL_IP, 0));
        assert_eq!(block_errors(&reply), [(1, 2, 0)]);
        assert!(outcome.changed);
        assert_eq!(device.interface.applied, [CELL_IP]);
        // The same IP again is applied again (the interface may have lost it) but
        // changes nothing.
        let (outcome, _) = handle(&mut device, &set_ip(CELL_IP, 0));
        assert!(!outcome.changed);
        assert_eq!(device.interface.applied, [CELL_IP, CELL_IP]);
        // 0.0.0.0 removes the address.
        let (_, reply) = handle(&mut device, &set_ip(IpParameter::UNSET, 0));
        assert_eq!(block_errors(&reply), [(1, 2, 0)]);
        assert_eq!(
            device.interface.applied,
            [CELL_IP, CELL_IP, IpParameter::UNSET]
        );
        assert!(!device.current().ip.is_set());
    }

    #[test]
    fn an_ip_the_interface_refuses_is_answered_set_not_possible_and_kept_nowhere() {
        let mut device = responder("rc-robot");
        device.interface.refuse = true;
        let (outcome, reply) = handle(&mut device, &set_ip(CELL_IP, 1));
        assert_eq!(block_errors(&reply), [(1, 2, 5)]);
        assert!(!outcome.changed);
        assert_eq!(device.current().ip, IpParameter::UNSET);
        assert_eq!(device.permanent().ip, IpParameter::UNSET);
        assert_eq!(device.store.stored, None);
        // A name in the same transaction is still set: every block is answered alone.
        device.interface.refuse = false;
        handle(&mut device, &set_ip(CELL_IP, 0));
        device.interface.refuse = true;
        handle(&mut device, &set_name(b"cell1-robot", 1));
        let (_, reply) = handle(&mut device, &set(&[5, 6, 0, 2, 0, 4]));
        assert_eq!(block_errors(&reply), [(5, 6, 5)]);
        assert_eq!(device.current().ip, CELL_IP);
        assert_eq!(device.current().name_of_station.as_str(), "cell1-robot");
    }

    #[test]
    fn the_permanent_ip_is_applied_at_start_and_a_reset_applies_the_factory_one() {
        let store = MemoryStore {
            stored: Some(StationParameters {
                name_of_station: NameOfStation::new(b"cell1-robot").unwrap(),
                ip: CELL_IP,
            }),
        };
        let mut device = DcpResponder::new(
            identity(),
            named("rc-robot"),
            store,
            FakeInterface::default(),
        );
        assert_eq!(device.interface.applied, [CELL_IP]);
        let (_, reply) = handle(&mut device, &set(&[5, 6, 0, 2, 0, 4]));
        assert_eq!(block_errors(&reply), [(5, 6, 0)]);
        assert_eq!(device.interface.applied, [CELL_IP, IpParameter::UNSET]);
    }

    #[test]
    fn a_temporary_ip_deletes_the_stored_one_and_keeps_the_stored_name() {
        let mut device = responder("rc-robot");
        handle(&mut device, &set_name(b"cell1-robot", 1));
        handle(&mut device, &set_ip(CELL_IP, 1));
        assert_eq!(device.permanent().ip, CELL_IP);
        let s7 = IpParameter {
            address: Ipv4Addr::new(172, 16, 2, 10),
            subnet_mask: Ipv4Addr::new(255, 255, 255, 0),
            gateway: Ipv4Addr::new(172, 16, 2, 10),
        };
        let (_, reply) = handle(&mut device, &set_ip(s7, 0));
        assert_eq!(block_errors(&reply), [(1, 2, 0)]);
        assert_eq!(device.current().ip, s7);
        let stored = device.store.stored.clone().unwrap();
        assert_eq!(
            (stored.ip, device.permanent().ip),
            (IpParameter::UNSET, IpParameter::UNSET)
        );
        assert_eq!(stored.name_of_station.as_str(), "cell1-robot");
        // After a restart the station has no IP until a controller assigns one, and the
        // interface is left as it is.
        let restarted = DcpResponder::new(
            identity(),
            named("rc-robot"),
            MemoryStore {
                stored: Some(stored),
            },
            FakeInterface::default(),
        );
        assert!(!restarted.current().ip.is_set());
        assert!(restarted.interface.applied.is_empty());
        assert_eq!(restarted.current().name_of_station.as_str(), "cell1-robot");
    }

    #[test]
    fn a_store_failure_puts_the_previous_ip_back_on_the_interface() {
        let mut device = DcpResponder::new(
            identity(),
            named("rc-robot"),
            BrokenStore,
            FakeInterface::default(),
        );
        let (_, reply) = handle(&mut device, &set_ip(CELL_IP, 1));
        assert_eq!(block_errors(&reply), [(1, 2, 4)]);
        assert_eq!(device.interface.applied, [CELL_IP, IpParameter::UNSET]);
        assert_eq!(device.current().ip, IpParameter::UNSET);
    }

    #[test]
    fn signal_is_reported_to_the_shell() {
        let mut device = responder("rc-robot");
        let (outcome, reply) = handle(&mut device, &set(&[5, 3, 0, 4, 0, 0, 1, 0]));
        assert!(outcome.signal);
        assert!(!outcome.changed);
        assert_eq!(block_errors(&reply), [(5, 3, 0)]);
        let (outcome, reply) = handle(&mut device, &set(&[5, 3, 0, 4, 0, 0, 2, 0]));
        assert!(!outcome.signal);
        assert_eq!(block_errors(&reply), [(5, 3, 5)]);
    }

    #[test]
    fn a_set_transaction_answers_every_block() {
        let mut device = responder("rc-robot");
        let mut data = vec![5, 1, 0, 2, 0, 0];
        data.extend_from_slice(&[1, 2, 0, 14, 0, 1, 10, 0, 0, 5, 255, 0, 0, 0, 10, 0, 0, 1]);
        data.extend_from_slice(&[2, 6, 0, 2, 0, 0]); // alias: not supported
        data.extend_from_slice(&[7, 1, 0, 2, 0, 0]); // unknown option
        data.extend_from_slice(&[5, 2, 0, 2, 0, 0]);
        let (_, reply) = handle(&mut device, &set(&data));
        assert_eq!(
            block_errors(&reply),
            [(5, 1, 0), (1, 2, 0), (2, 6, 2), (7, 1, 1), (5, 2, 0)]
        );
        assert_eq!(device.permanent().ip.address, Ipv4Addr::new(10, 0, 0, 5));
    }

    #[test]
    fn get_reads_the_name_and_refuses_what_it_does_not_have() {
        let mut device = responder("rc-robot");
        // profinet-py sends a 4-byte block but DCPDataLength 2: only the pair counts.
        let mut frame = request(DEVICE, frame_id::DCP_GET_SET, 3, 0, &[2, 2]);
        frame.extend_from_slice(&[0, 0]);
        let (_, reply) = handle(&mut device, &frame);
        assert_eq!(&reply[14..18], &[0xfe, 0xfd, 3, 1]);
        let values = block_values(&reply);
        assert_eq!(values, [(block::NAME_OF_STATION, b"\0\0rc-robot".to_vec())]);
        let frame = request(DEVICE, frame_id::DCP_GET_SET, 3, 0, &[1, 1, 2, 6]);
        let values = block_values(&handle(&mut device, &frame).1);
        assert_eq!(
            values[0],
            (block::MAC_ADDRESS, [&[0u8, 0][..], &DEVICE.0].concat())
        );
        assert_eq!(values[1], (block::CONTROL_RESPONSE, vec![2, 6, 2]));
    }

    #[test]
    fn frames_not_for_this_device_are_ignored() {
        let mut device = responder("rc-robot");
        let other = MacAddress([2, 0, 0, 0, 0, 9]);
        let ignored = [
            set_name(b"x", 0)
                .into_iter()
                .enumerate()
                .map(|(i, b)| if i < 6 { other.0[i] } else { b })
                .collect::<Vec<u8>>(),
            request(MacAddress::DCP_IDENTIFY, frame_id::DCP_GET_SET, 4, 0, &[]),
            request(MacAddress::DCP_IDENTIFY, 0xfeff, 5, 0, &[0xff, 0xff, 0, 0]),
            request(MacAddress::DCP_IDENTIFY, 0xfefe, 3, 0, &[0xff, 0xff, 0, 0]),
            request(MacAddress::DCP_IDENTIFY, 0x8000, 5, 0, &[0xff, 0xff, 0, 0]),
            vec![0; 10],
        ];
        for frame in ignored {
            assert_eq!(
                handle(&mut device, &frame).0,
                DcpOutcome::default(),
                "{frame:02x?}"
            );
        }
        let mut response = set_name(b"x", 0);
        response[15 + 2] = 1; // ServiceType response
        assert_eq!(handle(&mut device, &response).0, DcpOutcome::default());
    }

    #[test]
    fn a_malformed_request_is_an_error() {
        let mut device = responder("rc-robot");
        let mut out = [0u8; MAX_FRAME_LEN];
        let frame = set(&[2, 2, 0, 40, 0, 0]);
        assert!(matches!(
            device.handle(&frame, &mut out),
            Err(DcpError::BlockLength { .. })
        ));
    }

    proptest! {
        #[test]
        fn any_frame_is_handled_without_panic_and_replies_fit(
            frame_id in prop_oneof![Just(0xfefeu16), Just(0xfefd), any::<u16>()],
            service in 0u8..8,
            to_device in any::<bool>(),
            data in proptest::collection::vec(any::<u8>(), 0..80),
        ) {
            let destination = if to_device { DEVICE } else { MacAddress::DCP_IDENTIFY };
            let frame = request(destination, frame_id, service, 3, &data);
            let mut device = responder("rc-robot");
            let mut out = [0u8; MAX_FRAME_LEN];
            if let Ok(DcpOutcome { reply: Some(reply), .. }) = device.handle(&frame, &mut out) {
                prop_assert!(reply.len >= 60 && reply.len <= MAX_FRAME_LEN);
                let (header, payload) = EthernetHeader::parse(&out[..reply.len]).unwrap();
                prop_assert_eq!(header.destination, PLC);
                let (dcp, _) = DcpHeader::parse(&payload[2..]).unwrap();
                prop_assert_eq!(dcp.xid, 0x1234_5678);
                prop_assert_eq!(dcp.service_type, ServiceType::ResponseSuccess);
            }
        }
    }
}
