import { describe, expect, it } from "vitest";
import { plainValidation, sentence } from "../../src/lib/messages";

describe("sentence", () => {
  it("makes one sentence with one full stop", () => {
    expect(sentence("Take off", "accepted.")).toBe("Take off: accepted.");
    expect(sentence("Done..")).toBe("Done.");
    expect(sentence("", null, "ok")).toBe("Ok.");
  });
  it("drops a part that repeats another", () => {
    expect(sentence("Take off", "Refused by the vehicle", "refused by the vehicle (FAILED)")).toBe(
      "Take off: refused by the vehicle (FAILED).",
    );
    expect(sentence("Link down", "link down")).toBe("Link down.");
  });
  it("keeps names and acronyms as written", () => {
    expect(sentence("Arm", "PreArm: Need Position Estimate")).toBe("Arm: PreArm: Need Position Estimate.");
    expect(sentence("Mode", "GUIDED")).toBe("Mode: GUIDED.");
  });
});

describe("plainValidation", () => {
  it("turns pydantic's wording into plain words", () => {
    expect(plainValidation("Invalid input: altitude_m: Input should be greater than 0.")).toBe("altitude (m): must be more than 0.");
    expect(plainValidation("value: Input should be less than or equal to 100")).toBe("value: must be at most 100");
    expect(plainValidation("strategy: Input should be 'plnd' or 'guided'")).toBe("strategy: must be plnd or guided");
  });
});
