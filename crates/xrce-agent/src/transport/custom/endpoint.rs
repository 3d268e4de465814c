//! The endpoint of a custom transport (eProsima's `CustomEndPoint`): named members of fixed types that say
//! where a message came from or goes to, declared by the user once ([`EndpointDesc`]), filled by the user's
//! `read` for each message received, and read back by the user's `write` for each reply.
//!
//! Members are looked up by name among a handful, so a linear scan is the fastest and simplest table.
//! Every misuse (an unknown name, a type other than the declared one, a member left unset) is an
//! [`EndpointError`] naming the member, never a panic.

use std::fmt;
use std::sync::Arc;

/// The type of an endpoint member: eProsima's members are unsigned integers and strings.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum MemberKind {
    /// `u8`.
    U8,
    /// `u16`.
    U16,
    /// `u32`.
    U32,
    /// `u64`.
    U64,
    /// `String`.
    String,
}

impl fmt::Display for MemberKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::U8 => "u8",
            Self::U16 => "u16",
            Self::U32 => "u32",
            Self::U64 => "u64",
            Self::String => "String",
        })
    }
}

/// The value of a set member.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub enum MemberValue {
    /// A `u8` member.
    U8(u8),
    /// A `u16` member.
    U16(u16),
    /// A `u32` member.
    U32(u32),
    /// A `u64` member.
    U64(u64),
    /// A string member.
    String(String),
}

impl MemberValue {
    /// The value's type.
    pub fn kind(&self) -> MemberKind {
        match self {
            Self::U8(_) => MemberKind::U8,
            Self::U16(_) => MemberKind::U16,
            Self::U32(_) => MemberKind::U32,
            Self::U64(_) => MemberKind::U64,
            Self::String(_) => MemberKind::String,
        }
    }
}

impl fmt::Display for MemberValue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::U8(v) => write!(f, "{v}"),
            Self::U16(v) => write!(f, "{v}"),
            Self::U32(v) => write!(f, "{v}"),
            Self::U64(v) => write!(f, "{v}"),
            Self::String(v) => write!(f, "{v:?}"),
        }
    }
}

/// A type an endpoint member can have (`u8`, `u16`, `u32`, `u64`, `String`): the `T` of eProsima's
/// `add_member<T>`, `set_member<T>`, `get_member<T>`.
pub trait Member: Sized + sealed::Sealed {
    /// The member type it stands for.
    const KIND: MemberKind;
    /// Wraps a value.
    fn into_value(self) -> MemberValue;
    /// Unwraps a value of this type.
    fn from_value(value: &MemberValue) -> Option<Self>;
}

mod sealed {
    pub trait Sealed {}
}

macro_rules! member {
    ($($t:ty => $variant:ident),*) => {
        $(
            impl sealed::Sealed for $t {}
            impl Member for $t {
                const KIND: MemberKind = MemberKind::$variant;
                fn into_value(self) -> MemberValue {
                    MemberValue::$variant(self)
                }
                fn from_value(value: &MemberValue) -> Option<Self> {
                    match value {
                        MemberValue::$variant(v) => Some(v.clone()),
                        _ => None,
                    }
                }
            }
        )*
    };
}

member!(u8 => U8, u16 => U16, u32 => U32, u64 => U64, String => String);

/// What went wrong with an endpoint member.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum EndpointError {
    /// No member of this name was declared.
    #[error("the endpoint has no member `{0}`")]
    NoSuchMember(String),
    /// The member was declared with another type.
    #[error("endpoint member `{name}` is a {declared}, not a {requested}")]
    WrongType {
        /// The member.
        name: String,
        /// Its declared type.
        declared: MemberKind,
        /// The type asked for.
        requested: MemberKind,
    },
    /// The member has no value (the transport's `read` did not set it).
    #[error("endpoint member `{0}` is not set")]
    Unset(String),
    /// Two members were declared with the same name.
    #[error("endpoint member `{0}` is declared twice")]
    Duplicate(String),
}

/// The members of a custom transport's endpoints, declared once (eProsima's `CustomEndPoint::add_member`).
///
/// ```
/// use xrce_agent::transport::custom::EndpointDesc;
///
/// let desc = EndpointDesc::new().member_u32("ip").member_u16("port");
/// let mut endpoint = desc.endpoint();
/// endpoint.set("ip", 0x7F00_0001u32).unwrap();
/// endpoint.set("port", 8888u16).unwrap();
/// assert_eq!(endpoint.get::<u16>("port"), Ok(8888));
/// assert!(endpoint.get::<u32>("port").is_err(), "declared as u16");
/// ```
#[derive(Debug, Clone, Default)]
pub struct EndpointDesc {
    members: Vec<(String, MemberKind)>,
    /// The first name declared twice by the chaining methods, reported by [`Self::validate`].
    duplicate: Option<String>,
}

impl EndpointDesc {
    /// No members yet (an endpoint without members stands for a single peer).
    pub fn new() -> Self {
        Self::default()
    }

    /// Declares a member of type `T` (chaining; a name declared twice is reported by [`Self::validate`], which
    /// the custom agent calls).
    #[must_use]
    pub fn member<T: Member>(mut self, name: &str) -> Self {
        if let Err(EndpointError::Duplicate(name)) = self.add_member::<T>(name) {
            self.duplicate.get_or_insert(name);
        }
        self
    }

    /// Declares a `u8` member.
    #[must_use]
    pub fn member_u8(self, name: &str) -> Self {
        self.member::<u8>(name)
    }

    /// Declares a `u16` member.
    #[must_use]
    pub fn member_u16(self, name: &str) -> Self {
        self.member::<u16>(name)
    }

    /// Declares a `u32` member.
    #[must_use]
    pub fn member_u32(self, name: &str) -> Self {
        self.member::<u32>(name)
    }

    /// Declares a `u64` member.
    #[must_use]
    pub fn member_u64(self, name: &str) -> Self {
        self.member::<u64>(name)
    }

    /// Declares a string member.
    #[must_use]
    pub fn member_string(self, name: &str) -> Self {
        self.member::<String>(name)
    }

    /// eProsima's `add_member<T>(name)`: declares a member, or says it exists already.
    pub fn add_member<T: Member>(&mut self, name: &str) -> Result<(), EndpointError> {
        if self.members.iter().any(|(n, _)| n == name) {
            return Err(EndpointError::Duplicate(name.to_owned()));
        }
        self.members.push((name.to_owned(), T::KIND));
        Ok(())
    }

    /// The declared members, in order.
    pub fn members(&self) -> impl Iterator<Item = (&str, MemberKind)> {
        self.members.iter().map(|(n, k)| (n.as_str(), *k))
    }

    /// Whether the declaration is usable (no name declared twice).
    pub fn validate(&self) -> Result<(), EndpointError> {
        match &self.duplicate {
            Some(name) => Err(EndpointError::Duplicate(name.clone())),
            None => Ok(()),
        }
    }

    /// An endpoint of these members, none set.
    pub fn endpoint(&self) -> Endpoint {
        let desc: Arc<[(String, MemberKind)]> = self.members.clone().into();
        Endpoint { values: vec![None; desc.len()], desc }
    }
}

/// One endpoint: a value for each declared member (eProsima's `CustomEndPoint` with its values). The custom
/// agent hands a blank one to the transport's `read`, which must set every member, and the one a client's
/// messages came from to `write`, for its replies. Equal values make the same endpoint.
#[derive(Clone)]
pub struct Endpoint {
    desc: Arc<[(String, MemberKind)]>,
    values: Vec<Option<MemberValue>>,
}

impl Endpoint {
    fn slot(&self, name: &str, requested: MemberKind) -> Result<usize, EndpointError> {
        let (index, (_, declared)) = self
            .desc
            .iter()
            .enumerate()
            .find(|(_, (n, _))| n == name)
            .ok_or_else(|| EndpointError::NoSuchMember(name.to_owned()))?;
        if *declared != requested {
            return Err(EndpointError::WrongType { name: name.to_owned(), declared: *declared, requested });
        }
        Ok(index)
    }

    /// eProsima's `set_member<T>(name, value)`.
    pub fn set<T: Member>(&mut self, name: &str, value: T) -> Result<(), EndpointError> {
        let index = self.slot(name, T::KIND)?;
        if let Some(slot) = self.values.get_mut(index) {
            *slot = Some(value.into_value());
        }
        Ok(())
    }

    /// Sets a string member from a `&str`.
    pub fn set_str(&mut self, name: &str, value: &str) -> Result<(), EndpointError> {
        self.set(name, value.to_owned())
    }

    /// eProsima's `get_member<T>(name)`: a copy of the member's value.
    pub fn get<T: Member>(&self, name: &str) -> Result<T, EndpointError> {
        let index = self.slot(name, T::KIND)?;
        self.values
            .get(index)
            .and_then(Option::as_ref)
            .and_then(T::from_value)
            .ok_or_else(|| EndpointError::Unset(name.to_owned()))
    }

    /// A string member, borrowed.
    pub fn get_str(&self, name: &str) -> Result<&str, EndpointError> {
        let index = self.slot(name, MemberKind::String)?;
        match self.values.get(index) {
            Some(Some(MemberValue::String(s))) => Ok(s),
            _ => Err(EndpointError::Unset(name.to_owned())),
        }
    }

    /// Unsets every member (eProsima's `reset`).
    pub fn reset(&mut self) {
        self.values.iter_mut().for_each(|v| *v = None);
    }

    /// Every member is set (eProsima's `check_non_empty_members`), or the first one that is not.
    pub fn check_complete(&self) -> Result<(), EndpointError> {
        match self.desc.iter().zip(&self.values).find(|(_, v)| v.is_none()) {
            Some(((name, _), _)) => Err(EndpointError::Unset(name.clone())),
            None => Ok(()),
        }
    }

    /// The members with their values, in declaration order.
    pub fn members(&self) -> impl Iterator<Item = (&str, Option<&MemberValue>)> {
        self.desc.iter().zip(&self.values).map(|((n, _), v)| (n.as_str(), v.as_ref()))
    }
}

impl PartialEq for Endpoint {
    fn eq(&self, other: &Self) -> bool {
        // Endpoints of one agent share their declaration; only the values differ.
        self.values == other.values
    }
}

impl Eq for Endpoint {}

impl std::hash::Hash for Endpoint {
    fn hash<H: std::hash::Hasher>(&self, state: &mut H) {
        self.values.hash(state);
    }
}

/// `ip=2130706433, port=8888`; `-` for an unset member.
impl fmt::Display for Endpoint {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, (name, value)) in self.members().enumerate() {
            if i > 0 {
                f.write_str(", ")?;
            }
            match value {
                Some(v) => write!(f, "{name}={v}")?,
                None => write!(f, "{name}=-")?,
            }
        }
        Ok(())
    }
}

impl fmt::Debug for Endpoint {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Endpoint({self})")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn desc() -> EndpointDesc {
        EndpointDesc::new().member_u8("bus").member_u16("port").member_u32("ip").member_u64("id").member_string("name")
    }

    #[test]
    fn every_type_round_trips() {
        let mut e = desc().endpoint();
        e.set("bus", 3u8).unwrap();
        e.set("port", 8888u16).unwrap();
        e.set("ip", 0x7F00_0001u32).unwrap();
        e.set("id", u64::MAX).unwrap();
        e.set_str("name", "uart0").unwrap();
        assert_eq!(e.get::<u8>("bus"), Ok(3));
        assert_eq!(e.get::<u16>("port"), Ok(8888));
        assert_eq!(e.get::<u32>("ip"), Ok(0x7F00_0001));
        assert_eq!(e.get::<u64>("id"), Ok(u64::MAX));
        assert_eq!(e.get::<String>("name").as_deref(), Ok("uart0"));
        assert_eq!(e.get_str("name"), Ok("uart0"));
        assert_eq!(e.check_complete(), Ok(()));
        assert_eq!(e.to_string(), "bus=3, port=8888, ip=2130706433, id=18446744073709551615, name=\"uart0\"");
    }

    #[test]
    fn a_wrong_type_is_an_error_naming_both_types() {
        let mut e = desc().endpoint();
        let err = e.set("port", 1u32).unwrap_err();
        assert_eq!(
            err,
            EndpointError::WrongType { name: "port".into(), declared: MemberKind::U16, requested: MemberKind::U32 }
        );
        assert_eq!(err.to_string(), "endpoint member `port` is a u16, not a u32");
        assert!(matches!(e.get::<String>("ip"), Err(EndpointError::WrongType { .. })));
        assert!(matches!(e.get_str("bus"), Err(EndpointError::WrongType { .. })));
        assert!(matches!(e.set_str("id", "x"), Err(EndpointError::WrongType { .. })));
        assert_eq!(e.get::<u16>("port"), Err(EndpointError::Unset("port".into())), "the wrong set left it unset");
    }

    #[test]
    fn an_unknown_member_is_an_error() {
        let mut e = desc().endpoint();
        assert_eq!(e.set("prot", 1u16), Err(EndpointError::NoSuchMember("prot".into())));
        assert_eq!(e.get::<u16>("prot"), Err(EndpointError::NoSuchMember("prot".into())));
        assert_eq!(e.get_str("nom"), Err(EndpointError::NoSuchMember("nom".into())));
        assert_eq!(
            EndpointDesc::new().endpoint().get::<u8>("x").unwrap_err().to_string(),
            "the endpoint has no member `x`"
        );
    }

    #[test]
    fn unset_members_are_reported_until_set_and_after_reset() {
        let mut e = desc().endpoint();
        assert_eq!(e.get::<u8>("bus"), Err(EndpointError::Unset("bus".into())));
        assert_eq!(e.get_str("name"), Err(EndpointError::Unset("name".into())));
        assert_eq!(e.check_complete(), Err(EndpointError::Unset("bus".into())));
        e.set("bus", 1u8).unwrap();
        assert_eq!(e.check_complete(), Err(EndpointError::Unset("port".into())), "the first unset one");
        e.reset();
        assert_eq!(e.get::<u8>("bus"), Err(EndpointError::Unset("bus".into())));
        assert_eq!(e.to_string(), "bus=-, port=-, ip=-, id=-, name=-");
        assert_eq!(EndpointDesc::new().endpoint().check_complete(), Ok(()), "no members: always complete");
    }

    #[test]
    fn duplicate_names_are_refused() {
        let mut d = EndpointDesc::new().member_u32("ip");
        assert_eq!(d.add_member::<u16>("ip"), Err(EndpointError::Duplicate("ip".into())));
        assert_eq!(d.validate(), Ok(()), "add_member refused it, nothing was declared");
        let chained = d.member_u16("port").member_string("port");
        assert_eq!(chained.validate(), Err(EndpointError::Duplicate("port".into())));
        assert_eq!(chained.members().collect::<Vec<_>>(), [("ip", MemberKind::U32), ("port", MemberKind::U16)]);
    }

    #[test]
    fn endpoints_are_equal_by_value() {
        use std::collections::HashSet;
        let d = desc();
        let mut a = d.endpoint();
        let mut b = d.endpoint();
        a.set("port", 1u16).unwrap();
        b.set("port", 1u16).unwrap();
        assert_eq!(a, b);
        let set: HashSet<Endpoint> = [a.clone(), b.clone()].into();
        assert_eq!(set.len(), 1);
        b.set_str("name", "other").unwrap();
        assert_ne!(a, b);
    }
}
