//! Object variants and their representations (spec §7): by reference, as XML, or as an eProsima binary blob.

pub mod binary;

pub use binary::{
    BinaryObject, DataReaderBinary, DataReaderQos, DataWriterBinary, DataWriterQos, EndpointQos, ParticipantBinary,
    PubSubBinary, QosFlags, RequesterBinary, TopicBinary,
};

use crate::cdr::{Decode, Encode, Endianness, Error, Reader, Result, Seq, Writer};
use crate::types::{ClientKey, ObjectId, ObjectKind, Property};

/// Representation format discriminators.
pub mod format {
    /// `REPRESENTATION_BY_REFERENCE`.
    pub const BY_REFERENCE: u8 = 0x01;
    /// `REPRESENTATION_AS_XML_STRING`.
    pub const AS_XML_STRING: u8 = 0x02;
    /// `REPRESENTATION_IN_BINARY`.
    pub const IN_BINARY: u8 = 0x03;
}

/// How an object is described.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Representation<'a> {
    /// Name of a profile the agent knows.
    Reference(&'a str),
    /// Fast DDS XML text.
    Xml(&'a str),
    /// Binary blob; decoded as [`BinaryObject::Raw`], typed on demand with [`BinaryObject::decode_as`].
    Binary(BinaryObject<'a>),
}

impl<'a> Representation<'a> {
    /// The union discriminator.
    pub const fn format(&self) -> u8 {
        match self {
            Self::Reference(_) => format::BY_REFERENCE,
            Self::Xml(_) => format::AS_XML_STRING,
            Self::Binary(_) => format::IN_BINARY,
        }
    }

    /// Decodes a representation whose discriminator must be one of `allowed`.
    fn decode_allowed(r: &mut Reader<'a>, allowed: &[u8]) -> Result<Self> {
        let discriminator = r.read_u8()?;
        if !allowed.contains(&discriminator) {
            return Err(Error::InvalidDiscriminator(discriminator));
        }
        match discriminator {
            format::BY_REFERENCE => Ok(Self::Reference(r.read_string()?)),
            format::AS_XML_STRING => Ok(Self::Xml(r.read_string()?)),
            _ => Ok(Self::Binary(BinaryObject::Raw(r.read_octet_seq()?))),
        }
    }
}

impl Encode for Representation<'_> {
    fn encode(&self, w: &mut Writer<'_>) {
        w.write_u8(self.format());
        match self {
            Self::Reference(s) | Self::Xml(s) => w.write_string(s),
            Self::Binary(blob) => blob.encode_with_length(w),
        }
    }
}

/// Formats each union allows (spec §7.2).
const REPRESENTATION_3: &[u8] = &[format::BY_REFERENCE, format::AS_XML_STRING, format::IN_BINARY];
const BIN_AND_XML: &[u8] = &[format::AS_XML_STRING, format::IN_BINARY];
const REF_AND_XML: &[u8] = &[format::BY_REFERENCE, format::AS_XML_STRING];

/// What an entity hangs from: a domain for participants, a parent object for the others.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EntityLink {
    /// Participant's domain id (255: the agent's domain).
    Domain(i16),
    /// Parent object (participant, publisher or subscriber).
    Parent(ObjectId),
}

/// One of the 8 entity kinds the agent creates, with its representation and link.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EntityVariant<'a> {
    /// Participant … Replier.
    pub kind: ObjectKind,
    /// The description.
    pub representation: Representation<'a>,
    /// Domain or parent.
    pub link: EntityLink,
}

impl<'a> EntityVariant<'a> {
    /// A participant in `domain_id`.
    pub const fn participant(representation: Representation<'a>, domain_id: i16) -> Self {
        Self { kind: ObjectKind::Participant, representation, link: EntityLink::Domain(domain_id) }
    }

    /// Any other entity kind under `parent`.
    pub const fn child(kind: ObjectKind, representation: Representation<'a>, parent: ObjectId) -> Self {
        Self { kind, representation, link: EntityLink::Parent(parent) }
    }

    /// The parent object, if not a participant.
    pub const fn parent(&self) -> Option<ObjectId> {
        match self.link {
            EntityLink::Parent(id) => Some(id),
            EntityLink::Domain(_) => None,
        }
    }

    /// The domain id, for a participant.
    pub const fn domain_id(&self) -> Option<i16> {
        match self.link {
            EntityLink::Domain(d) => Some(d),
            EntityLink::Parent(_) => None,
        }
    }

    /// The binary blob decoded for this entity's kind, when the representation is binary.
    pub fn binary(&self, endian: Endianness) -> Option<Result<BinaryObject<'a>>> {
        match self.representation {
            Representation::Binary(blob) => Some(blob.decode_as(self.kind, endian)),
            _ => None,
        }
    }
}

/// `CLIENT_Representation` as eProsima lays it out (no timestamp, trailing `mtu`; spec §6.1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClientRepresentation<'a> {
    /// Must be `"XRCE"`.
    pub xrce_cookie: [u8; 4],
    /// Major, minor.
    pub xrce_version: [u8; 2],
    /// Vendor id.
    pub xrce_vendor_id: [u8; 2],
    /// Client key.
    pub client_key: ClientKey,
    /// Session id the client will use.
    pub session_id: u8,
    /// Optional properties (`uxr_sm`, `uxr_hl`).
    pub properties: Option<Seq<'a, Property<'a>>>,
    /// Client's maximum message size minus 4 (eProsima extension).
    pub mtu: u16,
}

impl<'a> ClientRepresentation<'a> {
    /// What an eProsima-compatible client sends.
    pub const fn new(client_key: ClientKey, session_id: u8, mtu: u16) -> Self {
        Self {
            xrce_cookie: crate::types::XRCE_COOKIE,
            xrce_version: crate::types::XRCE_VERSION,
            xrce_vendor_id: crate::types::VENDOR_EPROSIMA,
            client_key,
            session_id,
            properties: None,
            mtu,
        }
    }

    /// The `mtu` field of a client whose transport carries `transport_mtu` bytes, as eProsima's client fills it:
    /// 4 bytes less (`INTERNAL_RELIABLE_BUFFER_OFFSET`, the length word of its stream slots), `u16::MAX` above.
    pub fn mtu_for(transport_mtu: usize) -> u16 {
        u16::try_from(transport_mtu.saturating_sub(4)).unwrap_or(u16::MAX)
    }

    /// Value of property `name`, if present.
    pub fn property(&self, name: &str) -> Option<&'a str> {
        self.properties.as_ref()?.iter().find(|p| p.name == name).map(|p| p.value)
    }
}

impl<'a> Decode<'a> for ClientRepresentation<'a> {
    fn decode(r: &mut Reader<'a>) -> Result<Self> {
        Ok(Self {
            xrce_cookie: r.read_array()?,
            xrce_version: r.read_array()?,
            xrce_vendor_id: r.read_array()?,
            client_key: r.read()?,
            session_id: r.read_u8()?,
            properties: r.read_optional(|r| r.read())?,
            mtu: r.read_u16()?,
        })
    }
}

impl Encode for ClientRepresentation<'_> {
    fn encode(&self, w: &mut Writer<'_>) {
        self.encode_with(w, |w| w.write_optional(self.properties.as_ref(), |w, p| p.encode(w)));
    }
}

impl ClientRepresentation<'_> {
    /// Encodes the representation with `properties` in place of its own: how a client sends its CREATE_CLIENT,
    /// so its build links no decoder (a decoded [`Seq`] re-encodes by decoding its elements).
    pub fn encode_with_properties(&self, w: &mut Writer<'_>, properties: &[Property<'_>]) {
        let items = (!properties.is_empty()).then_some(properties);
        self.encode_with(w, |w| w.write_optional(items.as_ref(), |w, p| crate::cdr::write_seq(w, p)));
    }

    fn encode_with(&self, w: &mut Writer<'_>, properties: impl FnOnce(&mut Writer<'_>)) {
        // The fixed fields (no alignment among them) in one write (firmware size).
        let [c0, c1, c2, c3] = self.xrce_cookie;
        let [v0, v1] = self.xrce_version;
        let [d0, d1] = self.xrce_vendor_id;
        let [k0, k1, k2, k3] = self.client_key.0;
        w.write_bytes(&[c0, c1, c2, c3, v0, v1, d0, d1, k0, k1, k2, k3, self.session_id]);
        properties(w);
        w.write_u16(self.mtu);
    }
}

/// `AGENT_Representation` (spec §6.2 without the result).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AgentRepresentation<'a> {
    /// `"XRCE"`.
    pub xrce_cookie: [u8; 4],
    /// Major, minor.
    pub xrce_version: [u8; 2],
    /// Vendor id.
    pub xrce_vendor_id: [u8; 2],
    /// Properties; the C client cannot parse them, so agents never send any.
    pub properties: Option<Seq<'a, Property<'a>>>,
}

impl AgentRepresentation<'_> {
    /// What the eProsima agent sends.
    pub const EPROSIMA: Self = Self {
        xrce_cookie: crate::types::XRCE_COOKIE,
        xrce_version: crate::types::XRCE_VERSION,
        xrce_vendor_id: crate::types::VENDOR_EPROSIMA,
        properties: None,
    };
}

impl<'a> Decode<'a> for AgentRepresentation<'a> {
    fn decode(r: &mut Reader<'a>) -> Result<Self> {
        Ok(Self {
            xrce_cookie: r.read_array()?,
            xrce_version: r.read_array()?,
            xrce_vendor_id: r.read_array()?,
            properties: r.read_optional(|r| r.read())?,
        })
    }
}

impl Encode for AgentRepresentation<'_> {
    fn encode(&self, w: &mut Writer<'_>) {
        w.write_bytes(&self.xrce_cookie);
        w.write_bytes(&self.xrce_version);
        w.write_bytes(&self.xrce_vendor_id);
        w.write_optional(self.properties.as_ref(), |w, p| p.encode(w));
    }
}

/// `ObjectVariant`: a kind byte and the representation for that kind (spec §7.1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ObjectVariant<'a> {
    /// Participant … Replier.
    Entity(EntityVariant<'a>),
    /// TYPE, QOSPROFILE or APPLICATION: reference or XML only; parsed, never created by eProsima.
    Profile {
        /// Which of the three kinds.
        kind: ObjectKind,
        /// Reference or XML.
        representation: Representation<'a>,
    },
    /// The agent.
    Agent(AgentRepresentation<'a>),
    /// A client.
    Client(ClientRepresentation<'a>),
}

impl<'a> ObjectVariant<'a> {
    /// The kind byte.
    pub const fn kind(&self) -> ObjectKind {
        match self {
            Self::Entity(e) => e.kind,
            Self::Profile { kind, .. } => *kind,
            Self::Agent(_) => ObjectKind::Agent,
            Self::Client(_) => ObjectKind::Client,
        }
    }
}

impl<'a> Decode<'a> for ObjectVariant<'a> {
    fn decode(r: &mut Reader<'a>) -> Result<Self> {
        Self::decode_kinds(r)
    }
}

impl<'a> ObjectVariant<'a> {
    /// Every kind.
    fn decode_kinds(r: &mut Reader<'a>) -> Result<Self> {
        let kind_byte = r.read_u8()?;
        let kind = ObjectKind::from_nibble(kind_byte);
        if kind_byte > 0x0F {
            return Err(Error::InvalidDiscriminator(kind_byte));
        }
        let variant = match kind {
            ObjectKind::Participant => {
                let representation = Representation::decode_allowed(r, REPRESENTATION_3)?;
                Self::Entity(EntityVariant::participant(representation, r.read_i16()?))
            }
            ObjectKind::Publisher | ObjectKind::Subscriber => {
                let representation = Representation::decode_allowed(r, BIN_AND_XML)?;
                Self::Entity(EntityVariant::child(kind, representation, r.read()?))
            }
            ObjectKind::Topic
            | ObjectKind::DataWriter
            | ObjectKind::DataReader
            | ObjectKind::Requester
            | ObjectKind::Replier => {
                let representation = Representation::decode_allowed(r, REPRESENTATION_3)?;
                Self::Entity(EntityVariant::child(kind, representation, r.read()?))
            }
            ObjectKind::Type | ObjectKind::QosProfile | ObjectKind::Application => {
                Self::Profile { kind, representation: Representation::decode_allowed(r, REF_AND_XML)? }
            }
            ObjectKind::Agent => Self::Agent(r.read()?),
            ObjectKind::Client => Self::Client(r.read()?),
            _ => return Err(Error::InvalidDiscriminator(kind_byte)),
        };
        Ok(variant)
    }
}

impl Encode for ObjectVariant<'_> {
    fn encode(&self, w: &mut Writer<'_>) {
        w.write_u8(self.kind() as u8);
        match self {
            Self::Entity(e) => e.encode_body(w),
            Self::Profile { representation, .. } => representation.encode(w),
            Self::Agent(a) => a.encode(w),
            Self::Client(c) => c.encode(w),
        }
    }
}

impl EntityVariant<'_> {
    /// Encodes the entity as an `ObjectVariant`: its kind byte, then its body. A client creating entities
    /// encodes them this way, without [`ObjectVariant`]'s encoders of the agent's and a client's
    /// representations.
    pub fn encode_as_object(&self, w: &mut Writer<'_>) {
        w.write_u8(self.kind as u8);
        self.encode_body(w);
    }

    fn encode_body(&self, w: &mut Writer<'_>) {
        self.representation.encode(w);
        match self.link {
            EntityLink::Domain(d) => w.write_i16(d),
            EntityLink::Parent(id) => id.encode(w),
        }
    }
}

#[cfg(test)]
mod client_representation_tests {
    use super::ClientRepresentation;

    #[test]
    fn mtu_field_is_the_transport_mtu_minus_the_slot_word() {
        assert_eq!(ClientRepresentation::mtu_for(512), 508);
        assert_eq!(ClientRepresentation::mtu_for(2), 0);
        assert_eq!(ClientRepresentation::mtu_for(1 << 20), u16::MAX);
    }
}
