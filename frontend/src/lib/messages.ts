// One sentence per message: the parts joined without repeating themselves, one full
// stop at the end, raw validation wording turned into plain words.

/** Join sentence parts: drops empty and repeated parts (case-insensitive), one final stop. */
export function sentence(...parts: (string | null | undefined)[]): string {
  const seen = new Set<string>();
  const kept: string[] = [];
  for (const raw of parts) {
    const part = (raw ?? "").trim().replace(/[.\s]+$/, "");
    if (!part) continue;
    const key = part.toLowerCase();
    // "Refused by the vehicle" then "refused by the vehicle (FAILED)": keep the fuller one
    const dup = [...seen].find((s) => key.startsWith(s) || s.startsWith(key));
    if (dup !== undefined) {
      if (key.length > dup.length) {
        const i = kept.findIndex((k) => k.toLowerCase() === dup);
        kept[i] = part;
        seen.delete(dup);
        seen.add(key);
      }
      continue;
    }
    seen.add(key);
    kept.push(part);
  }
  if (kept.length === 0) return "";
  const text = kept.map((p, i) => (i === 0 ? p : lowerFirst(p))).join(": ");
  return `${upperFirst(text)}.`;
}

function upperFirst(s: string): string {
  return s.charAt(0).toUpperCase() + s.slice(1);
}

function lowerFirst(s: string): string {
  // keep acronyms and names (GUIDED, PreArm, PLND_TYPE) as they are
  return /^[A-Z][a-z]/.test(s) && !/^[A-Z][a-z]+[A-Z]/.test(s) ? s.charAt(0).toLowerCase() + s.slice(1) : s;
}

const VALIDATION: [RegExp, (m: RegExpMatchArray) => string][] = [
  [/Input should be greater than or equal to ([-\d.e]+)/i, (m) => `must be at least ${m[1]}`],
  [/Input should be greater than ([-\d.e]+)/i, (m) => `must be more than ${m[1]}`],
  [/Input should be less than or equal to ([-\d.e]+)/i, (m) => `must be at most ${m[1]}`],
  [/Input should be less than ([-\d.e]+)/i, (m) => `must be less than ${m[1]}`],
  [/Input should be a valid number.*/i, () => "must be a number"],
  [/Input should be '([^']+)' or '([^']+)'/i, (m) => `must be ${m[1]} or ${m[2]}`],
  [/Field required/i, () => "is missing"],
  [/Extra inputs are not permitted/i, () => "is not expected"],
];

/** A server sentence with pydantic's wording ("Input should be ...") made plain. */
export function plainValidation(text: string): string {
  let out = text;
  for (const [re, say] of VALIDATION) {
    out = out.replace(new RegExp(re.source, "gi"), (...args) => say(args as unknown as RegExpMatchArray));
  }
  // field paths like "altitude_m" read as words
  out = out.replace(/\b([a-z]+)_(m|s|mps|deg)\b/g, (_m, word: string, unit: string) => `${word.replace(/_/g, " ")} (${unit})`);
  return out.replace(/^Invalid input:\s*/i, "");
}
