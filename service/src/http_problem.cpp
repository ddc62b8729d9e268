// RFC 9457 problem documents (http_front.hpp): every refusal of the service, the front end's and the handlers'.
#include <nlohmann/json.hpp>

#include "http_front.hpp"

namespace runout::service {

namespace {
// The kinds of problem (docs/service.md, "Errors"): the URI's last segment and its title, by status and, where
// one status has several causes, by the field the refusal names.
struct ProblemKind {
  const char* slug;
  const char* title;
};
ProblemKind problem_kind(int status, const std::string& field) {
  switch (status) {
    case 400: return {"malformed-request", "The request cannot be read"};
    case 401: return {"unauthorized", "A write needs the service's bearer token"};
    case 404: return {"not-found", "No such resource"};
    case 405: return {"method-not-allowed", "Method not allowed on this path"};
    case 408: return {"request-timeout", "The request did not arrive in time"};
    case 409: return {"not-ready", "The resource is not in a state that allows this"};
    case 413: return {"body-too-large", "The request body is over the size limit"};
    case 414: return {"target-too-long", "The request target is too long"};
    case 415: return {"unsupported-media-type", "Unsupported media type or content coding"};
    case 417: return {"expectation-failed", "Unsupported expectation"};
    case 422:
      return field == "(budget)" ? ProblemKind{"over-work-budget", "Over the work budget"}
                                 : ProblemKind{"invalid-field", "A field of the request is invalid"};
    case 429:
      return field == "(budget)" ? ProblemKind{"over-work-budget", "Over the work budget"}
                                 : ProblemKind{"too-many-connections", "Too many connections from this client"};
    case 431: return {"head-too-large", "The request head is over the size limit"};
    case 501: return {"not-implemented", "Not implemented"};
    case 503: return {"overloaded", "The service is at its limit of connections or waiting requests"};
    case 505: return {"http-version-not-supported", "HTTP version not supported"};
    default: return {nullptr, nullptr};
  }
}
}  // namespace

std::string problem_type(int status, const std::string& field) {
  const ProblemKind k = problem_kind(status, field);
  return k.slug ? std::string("https://runout.invalid/problems/") + k.slug : "about:blank";
}

std::string problem_title(int status, const std::string& field) {
  const ProblemKind k = problem_kind(status, field);
  return k.title ? k.title : status >= 500 ? "Internal server error" : "Request refused";
}

std::string problem_body(int status, const std::string& instance, const std::vector<FieldError>& errors,
                         const std::string& extra_json) {
  using json = nlohmann::ordered_json;  // the RFC's members first, in its order
  const std::string first_field = errors.empty() ? std::string() : errors.front().field;
  json list = json::array();
  for (const auto& e : errors)
    if (!e.field.empty()) list.push_back({{"field", e.field}, {"message", e.message}});
  std::string detail = errors.empty() ? problem_title(status, first_field) : errors.front().message;
  if (!errors.empty() && !first_field.empty()) detail = first_field + ": " + detail;
  if (errors.size() > 1) {  // a last "(errors)" entry counts those not listed (FieldErrors, requests.hpp)
    const bool capped = errors.back().field == "(errors)";
    detail = (capped ? "more than " + std::to_string(errors.size() - 1) : std::to_string(errors.size())) +
             " fields are invalid (each in errors); the first, " + detail;
  }
  json j = {{"type", problem_type(status, first_field)},
            {"title", problem_title(status, first_field)},
            {"status", status},
            {"detail", detail}};
  if (!instance.empty()) j["instance"] = instance;
  j["errors"] = list;
  if (!extra_json.empty()) j.update(json::parse(extra_json));
  return j.dump(-1, ' ', false, json::error_handler_t::replace);
}

}  // namespace runout::service
