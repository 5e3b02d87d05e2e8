#include "nerfreg/registration/registration_result.h"

namespace nerfreg {

Json FieldAgreementJson(const FieldAgreement& g) {
  return {
      {"confidence", g.confidence}, {"cost", g.cost}, {"inside_fraction", g.inside_fraction}, {"samples", g.samples}};
}

Json RegistrationResult::ToJson() const {
  return {{"method", method},
          {"confidence", agreement.confidence},
          {"method_score", method_score},
          {"agreement", FieldAgreementJson(agreement)},
          {"field", field},
          {"target_from_source", MatrixToJson(target_from_source.ToMatrix())}};
}

}  // namespace nerfreg
