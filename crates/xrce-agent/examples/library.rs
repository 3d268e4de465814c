//! The agent as a library (eProsima's `AgentInstance` and `Agent` API, seed 003): start a UDP agent from
//! `MicroXRCEAgent`-style arguments, watch entities through a middleware callback, and create a client and
//! its entities in-process, as eProsima's `create_client` / `create_*_by_xml` do. docs/agent-api.md walks
//! through it.
//!
//! usage: cargo run -p xrce-agent --example library

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;

use xrce_agent::agent::{AgentHandle, AgentInstance};
use xrce_agent::middleware::callbacks::CallbackKind;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // The same words as the command line; port 0 picks a free port, `-m ced` keeps it off any DDS network.
    let mut instance = AgentInstance::create(["xrce-agent", "udp4", "-p", "0", "-m", "ced", "-v", "0"])?;
    println!("agent listening on {:?}", instance.local_addr());
    let AgentHandle::Udp(agent) = instance.agent().clone() else { return Err("a UDP agent".into()) };

    // Callbacks fire after each successful creation or deletion of their kind, from any client.
    let writers = Arc::new(AtomicUsize::new(0));
    let seen = writers.clone();
    agent.add_middleware_callback(CallbackKind::CreateDataWriter, move |_, entity| {
        seen.fetch_add(1, Ordering::Relaxed);
        println!("datawriter created: {entity:?}");
    });

    // A client created in-process (key 0xAABBCCDD, session 0x81, MTU 512) and its entities by XML; ids are
    // object numbers, parents given by number too. Flags: 0x02 REUSE, 0x04 REPLACE, as in a CREATE.
    let key = 0xAABB_CCDD;
    agent.create_client(key, 0x81, 512)?;
    agent.create_participant_by_xml(
        key,
        1,
        0,
        "<dds><participant><rtps><name>lib</name></rtps></participant></dds>",
        0x04,
    )?;
    agent.create_topic_by_xml(
        key,
        1,
        1,
        "<dds><topic><name>HelloWorldTopic</name><dataType>HelloWorld</dataType></topic></dds>",
        0x04,
    )?;
    agent.create_publisher_by_xml(key, 1, 1, "<dds><publisher></publisher></dds>", 0x04)?;
    agent.create_datawriter_by_xml(
        key,
        1,
        1,
        "<dds><data_writer><topic><kind>NO_KEY</kind><name>HelloWorldTopic</name>\
         <dataType>HelloWorld</dataType></topic></data_writer></dds>",
        0x04,
    )?;
    println!("callbacks saw {} datawriter(s)", writers.load(Ordering::Relaxed));

    // Everything goes with the client; `reset` would remove every client.
    agent.delete_client(key)?;
    instance.stop()?;
    Ok(())
}
