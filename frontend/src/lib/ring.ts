// Fixed-capacity ring buffer: the time-series plots keep the last N samples and
// never grow, however long the dashboard stays open.

export class Ring<T> {
  private readonly items: (T | undefined)[];
  private start = 0;
  private count = 0;

  constructor(readonly capacity: number) {
    if (!Number.isInteger(capacity) || capacity <= 0) {
      throw new RangeError(`capacity must be a positive integer, got ${capacity}`);
    }
    this.items = new Array<T | undefined>(capacity);
  }

  get length(): number {
    return this.count;
  }

  push(item: T): void {
    if (this.count < this.capacity) {
      this.items[(this.start + this.count) % this.capacity] = item;
      this.count += 1;
    } else {
      this.items[this.start] = item;
      this.start = (this.start + 1) % this.capacity;
    }
  }

  /** Oldest first. */
  toArray(): T[] {
    const out: T[] = [];
    for (let i = 0; i < this.count; i += 1) out.push(this.items[(this.start + i) % this.capacity] as T);
    return out;
  }

  last(): T | undefined {
    return this.count === 0 ? undefined : this.items[(this.start + this.count - 1) % this.capacity];
  }

  clear(): void {
    this.start = 0;
    this.count = 0;
    this.items.fill(undefined);
  }
}

/** Events per second over a sliding window (e.g. frames drawn on screen). */
export class RateMeter {
  private readonly times: Ring<number>;

  constructor(
    private readonly windowMs = 2000,
    capacity = 512,
  ) {
    if (!(windowMs > 0)) throw new RangeError(`windowMs must be > 0, got ${windowMs}`);
    this.times = new Ring<number>(capacity);
  }

  tick(nowMs: number): void {
    this.times.push(nowMs);
  }

  rate(nowMs: number): number {
    const recent = this.times.toArray().filter((t) => nowMs - t <= this.windowMs);
    if (recent.length < 2) return 0;
    const span = Math.max(nowMs - recent[0], 1);
    // n events within span: (n - 1) intervals, but the window is still open at nowMs
    return ((recent.length - 1) * 1000) / span;
  }
}
