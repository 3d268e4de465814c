/* Finding agents: GET_INFO by multicast (239.255.0.2:7400) or to a list of addresses, `attempts` times,
 * `period` ms apart; the callback gets each agent's locator and returns true to stop the search. They return
 * whether it did (the seed's `bool`; eProsima's return nothing, so calls written for either compile). */
#ifndef UXR_CLIENT_PROFILE_DISCOVERY_DISCOVERY_H_
#define UXR_CLIENT_PROFILE_DISCOVERY_DISCOVERY_H_
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <uxr/client/config.h>
#include <uxr/client/core/type/xrce_types.h>
#include <uxr/client/visibility.h>
#ifdef __cplusplus
extern "C" {
#endif
typedef bool (*uxrOnAgentFound)(const TransportLocator* locator, void* args);
UXRDLLAPI bool uxr_discovery_agents_default(uint32_t attempts, int period, uxrOnAgentFound on_agent_func,
                                            void* args);
UXRDLLAPI bool uxr_discovery_agents(uint32_t attempts, int period, uxrOnAgentFound on_agent_func, void* args,
                                    const TransportLocator* agent_list, size_t agent_list_size);
#ifdef __cplusplus
}
#endif
#endif /* UXR_CLIENT_PROFILE_DISCOVERY_DISCOVERY_H_ */
